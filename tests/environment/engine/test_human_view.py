"""The human view against hand-made states: what is drawn at which pixels."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.engine import human_view as hv
from sc2jax.environment.engine.human_view import HumanView
from sc2jax.environment.engine.rules.state import Order, Owner
from sc2jax.environment.engine.rules.units import UnitType
from tests.environment.helpers import PARAMS, small_sim


def _state(map_name, units):
    """A reset state of `map_name` whose first slots hold `units` (dicts of fields), the
    others empty."""
    sim = small_sim(map_name)
    state, _ = jax.jit(sim.reset)(jax.random.PRNGKey(0), PARAMS)
    u = jax.tree.map(np.array, state.units)
    u.alive[:] = False
    u.selected[:] = False
    u.orders[:] = Order.NONE
    for slot, fields in enumerate(units):
        u.alive[slot] = True
        for name, value in fields.items():
            getattr(u, name)[slot] = value
    return sim, state.replace(units=u)


def _marine(x, y, **fields):
    return {"type": UnitType.MARINE, "owner": Owner.SELF, "pos": (x, y), "health": 45.0,
            **fields}


def test_a_marine_is_drawn_as_a_disc_at_its_pixels():
    # MoveToBeacon's view: the playable area (22, 20)-(44, 36) and 3 units around it,
    # 28 world units over 256 pixels (9.14 a unit), 201 rows. A marine (radius 0.375,
    # 3.43 pixels) at (30, 30) is centred at column (30 - 19) * 9.14 = 100.6 and row
    # (39 - 30) * 9.14 = 82.3.
    sim, state = _state("MoveToBeacon", [_marine(30.0, 30.0)])
    view = HumanView(sim, 256)
    assert view.shape == (201, 256, 3)
    image = np.asarray(jax.jit(view.draw)(state))
    assert tuple(image[82, 100]) == hv.SELF_COLOUR  # Inside.
    assert tuple(image[82, 97]) != hv.SELF_COLOUR  # The rim, darker.
    assert np.all(image[82, 97] < image[82, 100] + 1)
    for row, column in ((82, 106), (88, 100), (76, 92)):  # Outside the disc.
        assert tuple(image[row, column]) not in (hv.SELF_COLOUR,)
    # Its health bar, full, above it: 6.9 pixels wide, 2 rows, ending a pixel above
    # the disc.
    assert tuple(image[77, 100]) == hv.HEALTH_COLOUR
    # The ground far from it is the terrain, the same with or without the marine.
    empty = np.asarray(jax.jit(view.draw)(_state("MoveToBeacon", [])[1]))
    np.testing.assert_array_equal(image[150:, 150:], empty[150:, 150:])
    np.testing.assert_array_equal(image[:60], empty[:60])


def test_damage_selection_and_orders_are_drawn():
    sim, state = _state("MoveToBeacon", [
        _marine(30.0, 30.0, health=22.5, selected=True, orders=(Order.MOVE, 0, 0, 0),
                order_pos=((40.0, 30.0),) * 4)])
    image = np.asarray(jax.jit(HumanView(sim, 256).draw)(state))
    # Half the health: the bar's left half green, its right half the lost colour.
    assert tuple(image[76, 98]) == hv.HEALTH_COLOUR
    assert tuple(image[76, 103]) == hv.HEALTH_LOST_COLOUR
    # The selection ring, 1 to 2.2 pixels beyond the disc (3.43 pixels).
    assert tuple(image[82, 100 - 5]) == hv.SELECTION_COLOUR
    # The move order's line along row 82 to the target at column 192.
    line = tuple(int(c) for c in hv._ORDER_COLOUR[Order.MOVE])
    for column in (120, 150, 190):
        assert tuple(image[82, column]) == line


@pytest.mark.slow
def test_shapes_of_beacons_shards_and_structures():
    sim, state = _state("MoveToBeacon", [
        dict(type=UnitType.BEACON, owner=Owner.NEUTRAL, pos=(30.0, 30.0))])
    image = np.asarray(jax.jit(HumanView(sim, 256).draw)(state))
    beacon = hv._TYPE_COLOUR[UnitType.BEACON]
    # A ring: radius 1.25 (11.4 pixels), hollow inside 0.6 of it.
    assert tuple(image[82, 100]) != beacon
    assert tuple(image[82, 100 + 9]) == beacon
    assert tuple(image[82, 100 + 13]) != beacon
    sim, state = _state("BuildMarines", [
        dict(type=UnitType.COMMAND_CENTER, owner=Owner.SELF, pos=(30.0, 28.0), health=1500.0),
        dict(type=UnitType.MINERAL_SHARD, owner=Owner.NEUTRAL, pos=(40.0, 30.0))])
    view = HumanView(sim, 256)
    image = np.asarray(jax.jit(view.draw)(state))
    cx, cy = np.asarray(view.to_pixels(np.float32([30.0, 28.0]))).astype(int)
    # A 5 x 5 footprint: a square 2.5 units each side of the centre, corners included.
    reach = int(2.5 * view.scale) - 2
    for dx, dy in ((reach, reach), (-reach, reach), (reach, -reach), (-reach, -reach)):
        assert tuple(image[cy + dy, cx + dx]) == hv.SELF_COLOUR
    sx, sy = np.asarray(view.to_pixels(np.float32([40.0, 30.0]))).astype(int)
    assert tuple(image[sy, sx]) == hv._TYPE_COLOUR[UnitType.MINERAL_SHARD]


def test_the_enemy_is_drawn_only_in_sight_on_a_fog_map():
    # FindAndDefeatZerglings: a marine sees 9 units around it.
    near = dict(type=UnitType.ZERGLING, owner=Owner.ENEMY, pos=(30.0, 26.0), health=35.0)
    far = dict(type=UnitType.ZERGLING, owner=Owner.ENEMY, pos=(48.0, 40.0), health=35.0)
    sim, state = _state("FindAndDefeatZerglings", [_marine(30.0, 30.0), near, far])
    view = HumanView(sim, 256)
    image = np.asarray(jax.jit(view.draw)(state))
    for pos, drawn in ((near["pos"], True), (far["pos"], False)):
        x, y = np.asarray(view.to_pixels(np.float32(pos))).astype(int)
        assert (tuple(image[y, x]) == hv.ENEMY_COLOUR) == drawn
    # Unexplored ground is darker than ground in sight.
    mx, my = np.asarray(view.to_pixels(np.float32([30.0, 33.0]))).astype(int)
    fx, fy = np.asarray(view.to_pixels(np.float32([48.0, 36.0]))).astype(int)
    assert image[fy, fx].sum() < image[my, mx].sum() / 2


def test_the_camera_rectangle_and_a_batch():
    sim, state = _state("MoveToBeacon", [_marine(30.0, 30.0)])
    view = HumanView(sim, 128)
    image = np.asarray(jax.jit(view.draw)(state))
    # The camera: 24 x 24 world units around its centre; its left edge is white.
    left, top = np.asarray(view.to_pixels(state.camera + np.float32([-12.0, 12.0])))
    row = int(top) + 10
    assert tuple(image[row, int(np.floor(left))]) == hv.CAMERA_COLOUR
    moved = state.replace(camera=state.camera + jnp.float32([3.0, 0.0]))
    batch = jax.tree.map(lambda a, b: jnp.stack([a, b]), state, moved)
    images = np.asarray(jax.jit(jax.vmap(view.draw))(batch))
    np.testing.assert_array_equal(images[0], image)
    np.testing.assert_array_equal(images[1], np.asarray(jax.jit(view.draw)(moved)))


@pytest.mark.parametrize("width, region", [(7, None), (256, (10.0, 5.0, 10.0, 20.0)),
                                           (True, None)])
def test_bad_settings_are_refused(width, region):
    with pytest.raises(ValueError, match="width|region"):
        HumanView(small_sim("MoveToBeacon"), width, region)


@pytest.mark.slow
def test_slot_sizes_draw_what_all_slots_draw():
    # BuildMarines draws from the leading 32, 96 or 200 slots, as its observations.
    sim = small_sim("BuildMarines", sized=True)
    state, _ = jax.jit(sim.reset)(jax.random.PRNGKey(1), PARAMS)
    every = small_sim("BuildMarines")
    assert sim.game.slot_sizes and int(state.units.alive.sum()) < 32
    np.testing.assert_array_equal(jax.jit(HumanView(sim, 192).draw)(state),
                                  jax.jit(HumanView(every, 192).draw)(state))
