"""Observations read by name: NamedNumpyArray, NamedDict, and the layers' indices."""

import copy
import pickle

import jax
import numpy as np
import pytest

from sc2jax.environment.interface import specs
from sc2jax.environment.interface.features import SCREEN_FEATURES
from sc2jax.environment.interface.layout import named, to_pysc2_layout
from sc2jax.environment.interface.named import NamedDict, NamedNumpyArray
from sc2jax.environment.interface.observation_tables import FeatureUnit, Player


def _cube():
    return NamedNumpyArray(np.arange(24).reshape(3, 2, 4),
                           [["a", "b", "c"], None, ["w", "x", "y", "z"]])


def test_names_index_their_dimension_by_attribute_and_by_key():
    cube = _cube()
    np.testing.assert_array_equal(cube.b, cube[1])
    np.testing.assert_array_equal(cube["c"], cube[2])
    np.testing.assert_array_equal(cube[:, :, "y"], cube[..., 2])
    assert cube.b.index_names == (None, ("w", "x", "y", "z"))
    assert cube.c.x.tolist() == [17, 21]
    np.testing.assert_array_equal(cube[["c", "a"]], cube[[2, 0]])
    table = NamedNumpyArray(np.arange(11), [Player])
    assert table.minerals == table[Player.minerals] == 1


def test_slices_keep_and_rename_names_and_other_indexing_drops_them():
    cube = _cube()
    assert cube[1:].index_names == (("b", "c"), None, ("w", "x", "y", "z"))
    assert cube[[2, 0]].index_names == (("c", "a"), None, ("w", "x", "y", "z"))
    assert cube[None].index_names == (None, ("a", "b", "c"), None, ("w", "x", "y", "z"))
    assert cube[..., 1].index_names == (("a", "b", "c"), None)
    assert (cube + 1).index_names == cube.index_names
    assert cube.sum(axis=0).index_names == (None, None)
    assert cube.reshape(6, 4).index_names == (None, None)
    assert type(cube.sum()) is np.int64  # A reduction to a scalar is numpy's scalar.
    rows = NamedNumpyArray(np.arange(10).reshape(2, 5), [None, list("xyzuv")])
    assert [int(row.y) for row in rows] == [1, 6]  # Rows keep their columns' names.
    assert rows[rows[:, 0] > 0].index_names == (None, tuple("xyzuv"))


def test_unknown_names_say_which_exist():
    cube = _cube()
    with pytest.raises(AttributeError, match="no attribute or index name 'q'; its names: "
                                             "dimension 0: a, b, c; dimension 2: w, x, y, z"):
        getattr(cube, "q")  # noqa: B009
    with pytest.raises(KeyError, match="no index named 'q' in dimension 0"):
        cube["q"]
    with pytest.raises(ValueError, match="2 names for a dimension of 3"):
        NamedNumpyArray(np.zeros(3), [["a", "b"]])
    with pytest.raises(AttributeError, match="no observation 'rgb_screen'"):
        getattr(NamedDict(player=1), "rgb_screen")  # noqa: B009


def test_names_survive_copies_and_pickles():
    cube = _cube()
    for copied in (pickle.loads(pickle.dumps(cube)), copy.deepcopy(cube)):
        assert copied.index_names == cube.index_names
        np.testing.assert_array_equal(copied.a, cube.a)


def test_a_layer_is_named_by_the_layers_rendered_not_pysc2s_full_list():
    fmt = specs.ObservationFormat(16, 16, screen_features=["selected", "player_relative"],
                                  use_feature_units=True)
    padded = {k: np.zeros(s.shape, s.dtype) if s.dtype != bool else np.zeros(s.shape, bool)
              for k, s in specs.observation_spec(fmt, padded=True).items()}
    padded["feature_screen"][1] = 4
    padded["feature_units"][0, FeatureUnit.unit_type] = 48
    obs = named(to_pysc2_layout(padded, "MoveToBeacon"), fmt)
    assert (obs.feature_screen.player_relative == 4).all()
    assert fmt.screen_index("player_relative") == 1
    assert SCREEN_FEATURES.player_relative.index == 5  # PySC2's: all 27 layers only.
    assert obs.feature_units[0].unit_type == 48 and obs.map_name == "MoveToBeacon"
    with pytest.raises(ValueError, match="screen layer 'unit_type' is not in this format; it "
                                         "has \\['selected', 'player_relative'\\]"):
        fmt.screen_index("unit_type")
    assert specs.ObservationFormat().minimap_index("camera") == 3


def test_a_named_observation_is_a_pytree_of_its_arrays():
    obs = NamedDict(b=np.ones(2), a=NamedNumpyArray(np.zeros(3), [["x", "y", "z"]]))
    doubled = jax.tree.map(lambda x: x * 2, obs)
    assert isinstance(doubled, NamedDict) and sorted(doubled) == ["a", "b"]
    np.testing.assert_array_equal(doubled.b, [2, 2])
