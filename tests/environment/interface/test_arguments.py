"""Tests for the argument types."""

import pytest

from sc2jax.environment import TYPES, resolve_types
from sc2jax.environment.interface.arguments import normalize_size


def test_types_match_pysc2():
    expected = [
        ("screen", (0, 0)), ("minimap", (0, 0)), ("screen2", (0, 0)), ("queued", (2,)),
        ("control_group_act", (5,)), ("control_group_id", (10,)), ("select_point_act", (4,)),
        ("select_add", (2,)), ("select_unit_act", (4,)), ("select_unit_id", (500,)),
        ("select_worker", (4,)), ("build_queue_id", (10,)), ("unload_id", (500,)),
    ]
    assert [(t.name, t.sizes) for t in TYPES] == expected
    assert [t.id for t in TYPES] == list(range(13))


def test_enum_values():
    assert [e.name for e in TYPES.queued.values] == ["now", "queued"]
    assert [e.name for e in TYPES.control_group_act.values] == [
        "recall", "set", "append", "set_and_steal", "append_and_steal"]
    assert [e.name for e in TYPES.select_point_act.values] == [
        "select", "toggle", "select_all_type", "add_all_type"]
    assert [e.name for e in TYPES.select_unit_act.values] == [
        "select", "deselect", "select_all_type", "deselect_all_type"]
    assert [e.name for e in TYPES.select_worker.values] == [
        "select", "add", "select_all", "add_all"]
    assert [e.name for e in TYPES.select_add.values] == ["select", "add"]


def test_resolve_types():
    types = resolve_types(84, (64, 32))
    assert types.screen.sizes == (84, 84) and types.screen2.sizes == (84, 84)
    assert types.minimap.sizes == (64, 32)
    assert types.queued.sizes == (2,)


@pytest.mark.parametrize("bad", [0, -3, (64,), (64, 0), "64", 1.5, True, (64, 64, 1)])
def test_bad_sizes(bad):
    with pytest.raises(ValueError, match="screen_size"):
        resolve_types(bad, 64)


def test_normalize_size_bounds():
    assert normalize_size(16, "s", 16, 256) == (16, 16)
    with pytest.raises(ValueError, match=r"s must be in \[16, 256\].*got 257"):
        normalize_size(257, "s", 16, 256)
