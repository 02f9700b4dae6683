"""Ladder-map layouts from replays: the packaged ones agree with the replays, are
point-symmetric (which checks the centres the footprints give), and a revised map's
replays are kept apart."""

import json
import pathlib

import numpy as np
import pytest

from sc2jax.environment.engine.ladder import MapLayout, layouts, load_layout
from sc2jax.replay_sl.layouts import map_layout, merge, replay_layout

REPLAYS = pathlib.Path(__file__).parents[3] / "shared" / "replays"
needs_replays = pytest.mark.skipif(not REPLAYS.is_dir(),
                                   reason=f"the replays are not at {REPLAYS}")


def _files(name: str) -> list[str]:
    manifest = json.loads((REPLAYS / "MANIFEST.json").read_text())
    return [str(REPLAYS / r["file"]) for r in manifest["replays"] if r["map"] == name]


@needs_replays
def test_a_replay_gives_the_packaged_layout():
    packaged = load_layout("Disco Bloodbath LE")
    for path in _files("Disco Bloodbath LE")[:2]:
        layout = replay_layout(path, "Disco Bloodbath LE")
        for field in ("map_size", "start_locations", "minerals", "geysers", "neutral_units"):
            assert getattr(layout, field) == getattr(packaged, field), field
        assert layout.replays[0] in packaged.replays
        assert not (layout.ground & ~packaged.ground).any()  # the union holds each replay's


@pytest.mark.parametrize("name", layouts())
def test_every_packaged_map_is_point_symmetric_with_a_base_at_each_start(name):
    """Two-player ladder maps are symmetric about their centre. A centre off by the
    half cell that rounding down loses would break the symmetry of 2 x 1 mineral fields
    and 3 x 3 geysers."""
    layout = load_layout(name)
    (ax, ay), (bx, by) = layout.start_locations
    for field in ("minerals", "geysers"):
        points = {p[:2] for p in getattr(layout, field)}
        assert {(ax + bx - x, ay + by - y) for x, y in points} == points, field
    w, h = layout.map_size
    assert layout.ground.shape == (h, w)
    x0, y0, x1, y1 = layout.playable
    assert 0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h
    minerals = np.array([p[:2] for p in layout.minerals])
    geysers = np.array([p[:2] for p in layout.geysers])
    for start in layout.start_locations:
        assert (np.linalg.norm(minerals - start, axis=1) < 10).sum() == 8
        assert (np.linalg.norm(geysers - start, axis=1) < 10).sum() == 2


@needs_replays
@pytest.mark.slow
def test_a_revised_map_keeps_its_most_common_revision():
    files = _files("Winter's Gate LE")
    lines = []
    layout = map_layout(files, "Winter's Gate LE", log=lines.append)
    assert len(layout.replays) == len(files) - 2
    assert lines and "2 replays of another revision left out" in lines[0]
    (other,) = [f for f in files if f.endswith("0052_WintersGate.SC2Replay")]
    revised = replay_layout(other, "Winter's Gate LE")  # the common revision moved 2 plates
    assert revised.replays[0] in lines[0]
    with pytest.raises(ValueError, match="differ in neutral_units"):
        merge([layout, revised])


def test_json_round_trip_and_unknown_maps():
    layout = load_layout("Acropolis LE")
    back = MapLayout.from_json(json.loads(json.dumps(layout.to_json())))
    assert back.minerals == layout.minerals and np.array_equal(back.ground, layout.ground)
    with pytest.raises(ValueError, match="no layout of map 'Nowhere LE'; the packaged ones: "
                                         r"\['Acropolis LE'"):
        load_layout("Nowhere LE")
