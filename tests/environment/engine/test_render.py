"""The renderer against a direct per-pixel reference, and its fusion barrier."""

import jax
import numpy as np
import pytest

from sc2jax.environment.engine import render
from sc2jax.environment.engine.minigames.base import flat_geometry
from sc2jax.environment.engine.rules.geometry import cell_lookup
from sc2jax.environment.engine.rules.state import Owner
from sc2jax.environment.engine.rules.units import UNIT_DATA
from sc2jax.environment.engine.xla.fusion import materialize, set_static
from sc2jax.environment.interface.camera import Camera, Minimap
from sc2jax.environment.interface.feature_units import ratio_255
from tests.environment.helpers import random_play, small_sim

_RELATIVE = {Owner.SELF: 1, Owner.ENEMY: 4, Owner.NEUTRAL: 3}


def test_materialize_is_an_identity():
    x = np.arange(4 * 5 * 6, dtype=np.int32).reshape(4, 5, 6) * 7 - 3
    np.testing.assert_array_equal(materialize(x), x)
    np.testing.assert_array_equal(jax.jit(materialize)(x), x)
    batch = np.stack([x, -x, x + 1])
    np.testing.assert_array_equal(jax.jit(jax.vmap(materialize))(batch), batch)
    # Inside a larger program, where XLA may fuse around it.
    doubled = jax.jit(lambda a: materialize(a * 2)[np.array([2, 0, 3])] >> 1)(x)
    np.testing.assert_array_equal(doubled, x[[2, 0, 3]])


def test_set_static_writes_the_rows_it_is_given_without_a_scatter():
    x = np.arange(12, dtype=np.int32).reshape(4, 3)
    values = {0: [7, 8, 9], 2: np.int64(5)}
    expected = x.copy()
    expected[0], expected[2] = [7, 8, 9], 5
    np.testing.assert_array_equal(set_static(x, values), expected)
    batch = np.stack([x, x + 1])
    rows = jax.jit(jax.vmap(lambda a: set_static(a, {1: a[1] * 2})))(batch)
    np.testing.assert_array_equal(rows[:, 1], batch[:, 1] * 2)
    np.testing.assert_array_equal(rows[:, [0, 2, 3]], batch[:, [0, 2, 3]])
    hlo = jax.jit(lambda a: set_static(a, {1: a[0]})).lower(x).as_text()
    assert "scatter" not in hlo


def test_pack_fields_fit_their_words_without_overlap():
    for word_bits in (21, 24):
        packing = render.pack_fields(render.FIELD_BITS, word_bits)
        assert set(packing) == set(render.FIELD_BITS)
        used = {}
        for name, (word, shift, bits) in packing.items():
            assert bits == render.FIELD_BITS[name] and shift + bits <= word_bits
            mask = ((1 << bits) - 1) << shift
            assert used.get(word, 0) & mask == 0
            used[word] = used.get(word, 0) | mask
    with pytest.raises(ValueError, match=r"unit_hit_points field \(13 bits\) does not fit"):
        render.pack_fields(render.FIELD_BITS, 12)


def test_paint_window_holds_every_pixel_a_unit_reaches_and_no_more():
    # Pixel k to one side of the unit's own is reached where |k + 0.5 - f| <= r, f the
    # centre's fraction of its pixel (float32, as `paint` computes it), f = 0 included.
    fractions = np.concatenate([np.linspace(0, 1, 1001, dtype=np.float32)[:-1],
                                [np.nextafter(np.float32(1), np.float32(0))]])
    offsets = np.arange(-12, 13)
    for r in [0.1875, 0.375, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 2.6666667, 3.1666667, 5.0]:
        r = np.float32(r)
        dx = offsets[:, None].astype(np.float32) + np.float32(0.5) - fractions[None, :]
        reached = offsets[(np.abs(dx) <= r).any(axis=1)]
        half = render.box_size(float(r)) // 2
        assert np.abs(reached).max() == half, (r, reached, half)


def reference_layers(sim, state, view: str = "screen") -> dict:
    """The per-unit layers of the screen or the minimap by the documented rule, pixel by
    pixel (numpy): a unit covers the pixels whose centres lie within its radius and the
    pixel holding its centre; the top unit is the highest render layer, then the
    highest slot."""
    units = jax.tree_util.tree_map(np.asarray, state.units)
    renderer = sim.renderer
    if view == "screen":
        grid = renderer.camera
        pos = grid.world_to_pixel(state.camera, state.units.pos)
    else:
        grid = renderer.minimap
        pos = grid.world_to_pixel(state.units.pos)
    shown = np.asarray(renderer.units_shown(state))
    pos = np.asarray(pos, np.float32)
    radius = (UNIT_DATA.radius[units.type] * np.float32(grid.pixels_per_unit)).astype(
        np.float32)
    w, h = grid.size
    ys, xs = np.mgrid[0:h, 0:w]
    dx = xs[..., None].astype(np.float32) + np.float32(0.5) - pos[:, 0]
    dy = ys[..., None].astype(np.float32) + np.float32(0.5) - pos[:, 1]
    centre = (np.floor(pos[:, 0]) == xs[..., None]) & (np.floor(pos[:, 1]) == ys[..., None])
    cover = shown & ((dy ** 2 + dx ** 2 <= radius * radius) | centre)  # [H, W, N]
    n = units.type.shape[0]
    rank = render._RENDER_LAYER[units.type] * n + np.arange(n)
    top = np.argmax(np.where(cover, rank, -1), axis=-1)
    covered = cover.any(-1)

    def layer(per_unit):
        return np.where(covered, np.asarray(per_unit)[top], 0)

    layers = {
        "player_relative": layer([_RELATIVE.get(int(o), 0) for o in units.owner]),
        "player_id": layer(units.owner),
        "selected": layer(units.selected),
    }
    if view == "minimap":
        return layers
    density = cover.sum(-1)
    return layers | {
        "unit_type": layer(UNIT_DATA.sc2_id[units.type]),
        "unit_hit_points": layer(np.ceil(units.health)),
        "unit_hit_points_ratio": layer(ratio_255(units.health,
                                                 UNIT_DATA.max_health[units.type])),
        "unit_density": np.minimum(density, 15),
        "unit_density_aa": np.minimum(density * 16, 255),
    }


def _random_states(sim, seed: int, steps: int):
    """States of a random episode, each also with three slots moved to overlap at the
    camera's centre (slot 1 over slot 0, the last slot under them)."""
    play = random_play(sim, seed, steps)
    next(play)  # The reset.
    out = []
    for _, state, _ in play:
        centre = np.asarray(state.camera)
        pos = np.array(state.units.pos)
        pos[[0, 1, -1]] = centre + np.array([[0.2, -0.2], [0.3, -0.1], [0.1, -0.3]])
        out += [state, state.replace(units=state.units.replace(pos=pos))]
    return out


@pytest.mark.parametrize("map_name,paints_every_word", [
    ("CollectMineralShards", True), ("FindAndDefeatZerglings", True),
    pytest.param("BuildMarines", False, marks=pytest.mark.slow), ("CollectMineralShards", False)])
def test_unit_layers_match_the_per_pixel_reference(map_name, paints_every_word,
                                                   monkeypatch):
    sim = small_sim(map_name)
    states = _random_states(sim, seed=5, steps=12)
    size = sim.renderer.camera.size
    assert render.paints_every_word(len(states[0].units.type), sim.renderer.screen_box,
                                    size) == (paints_every_word or map_name != "BuildMarines")
    monkeypatch.setattr(render, "paints_every_word", lambda *_: paints_every_word)
    screen = jax.jit(sim.renderer.screen)
    minimap = jax.jit(sim.renderer.minimap_layers)
    names = [f.name for f in sim.fmt.screen_layers]
    minimap_names = [f.name for f in sim.fmt.minimap_layers]
    covered = 0
    for state in states:
        got = np.asarray(screen(state))
        for name, want in reference_layers(sim, state).items():
            np.testing.assert_array_equal(got[names.index(name)], want, err_msg=name)
        covered += int((got[names.index("unit_density")] > 1).sum())
        got = np.asarray(minimap(state))
        for name, want in reference_layers(sim, state, "minimap").items():
            np.testing.assert_array_equal(got[minimap_names.index(name)], want,
                                          err_msg=f"minimap {name}")
    assert covered > 0  # Some pixels had overlapping units, so the draw order was tested.


@pytest.mark.parametrize("size", [64, 32, 24, 84])
@pytest.mark.parametrize("shift", [0.0, 3.0])
def test_minimap_lookups_at_fixed_points_match_the_traced_lookup(size, shift):
    # The minimap's pixel centres are numpy, so its lookups are slices (64, 32: one or
    # two cells per pixel) or a gather (24, 84, or shifted: some pixels off the map)
    # made while tracing; the same cells as the lookup at traced points.
    xs, ys = Minimap((size, size), (64, 64)).pixel_centers()
    xs, ys = xs - shift, ys + shift
    grid = np.random.default_rng(0).integers(0, 100, (64, 64)).astype(np.int32)
    traced = jax.jit(lambda g, x, y: cell_lookup(g, 64, x, y, -1))(grid, xs, ys)
    fixed_grid = jax.jit(lambda g: cell_lookup(g, 64, xs, ys, -1))(grid)
    np.testing.assert_array_equal(fixed_grid, traced)
    np.testing.assert_array_equal(cell_lookup(grid, 64, xs, ys, -1), traced)
    assert (np.asarray(traced) == -1).any() == (shift > 0)


@pytest.mark.parametrize("kind", ["terrain", "many_rows", "bool", "bool_70_wide"])
def test_screen_lookups_at_traced_points_match_the_cells(kind):
    # At traced points a fixed grid with few distinct rows (the terrain) is looked up by
    # its rows' patterns, a bool grid (the explored cells) by packed bits, and any other
    # grid by a gather: each the same cells as numpy's lookup, off the map included.
    rng = np.random.default_rng(1)
    grid = {
        "terrain": np.where(flat_geometry((10.0, 12.0, 54.0, 44.0)).pathable, 7, 3),
        "many_rows": rng.integers(0, 100, (64, 64)).astype(np.int32),
        "bool": rng.random((64, 64)) < 0.5,
        "bool_70_wide": rng.random((64, 70)) < 0.5,
    }[kind]
    fill = False if grid.dtype == bool else -1
    fixed = grid.dtype != bool
    lookup = jax.jit(lambda g, x, y: cell_lookup(grid if fixed else g, 64, x, y, fill))
    camera = Camera((64, 57))
    for center in rng.uniform(-5.0, 75.0, (12, 2)).astype(np.float32):
        xs, ys = (np.asarray(v) for v in camera.pixel_centers(center))
        want = cell_lookup(grid, 64, xs, ys, fill)
        np.testing.assert_array_equal(lookup(grid, xs, ys), want, err_msg=str(center))
