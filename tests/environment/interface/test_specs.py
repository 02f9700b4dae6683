"""Tests for the observation and action specs."""

import jax
import numpy as np
import pytest

from sc2jax.environment import (
    FUNCTIONS,
    ObservationFormat,
    Simulator,
    action_spec,
    make,
    observation_spec,
    to_dense,
)
from sc2jax.environment.engine.minigames import get_map
from sc2jax.environment.interface.layout import to_padded_layout, to_pysc2_layout


def test_pysc2_layout_shapes():
    spec = observation_spec(ObservationFormat(84, 64))
    assert spec["feature_screen"].shape == (27, 84, 84)
    assert spec["feature_minimap"].shape == (11, 64, 64)
    assert spec["feature_screen"].dtype == np.int32
    assert spec["player"].shape == (11,)
    assert spec["score_cumulative"].shape == (13,)
    assert spec["score_by_category"].shape == (11, 5)
    assert spec["score_by_vital"].shape == (3, 3)
    assert spec["control_groups"].shape == (10, 2)
    assert spec["game_loop"].shape == (1,)
    # Variable-length lists accept any length up to the maximum.
    spec["multi_select"].validate(np.zeros((3, 7), np.int32))
    spec["multi_select"].validate(np.zeros((0, 7), np.int32))
    spec["available_actions"].validate(np.array([0, 1, 2], np.int32))
    with pytest.raises(ValueError):
        spec["multi_select"].validate(np.zeros((3, 6), np.int32))
    with pytest.raises(ValueError):
        spec["multi_select"].validate(np.zeros((3, 7), np.int64))
    spec["map_name"].validate("MoveToBeacon")


def test_padded_layout_is_fixed():
    spec = observation_spec(ObservationFormat(32, 24, max_units=16, use_feature_units=True),
                            padded=True)
    assert spec["multi_select"].shape == (16, 7)
    assert spec["feature_units"].shape == (16, 46) and spec["feature_units"].dtype == np.int32
    pysc2 = observation_spec(ObservationFormat(use_feature_units=True))
    assert pysc2["feature_units"].dtype == np.int64
    assert spec["available_actions_mask"].shape == (573,)
    assert spec["available_actions_mask"].dtype == np.bool_
    assert spec["feature_minimap"].shape == (11, 24, 24)
    assert "map_name" not in spec


def test_a_key_means_one_thing_in_every_layout():
    # The mask and PySC2's ids have different names, so `FUNCTIONS.x.id in
    # obs["available_actions"]` is never silently False on a mask.
    fmt = ObservationFormat(16, 16)
    padded, pysc2 = observation_spec(fmt, padded=True), observation_spec(fmt)
    assert "available_actions" not in padded and "available_actions_mask" not in pysc2
    assert pysc2["available_actions"].dtype == np.int32
    shared = set(padded) & set(pysc2)
    assert shared == set(padded) - {"available_actions_mask"}
    for key in shared:  # The same dtype and trailing shape; only padding may differ.
        assert pysc2[key].shape[1:] == padded[key].shape[1:], key
        assert pysc2[key].dtype == padded[key].dtype or key in ("feature_units", "raw_units")
    obs = {k: np.zeros(s.shape, s.dtype) for k, s in padded.items()}
    obs["available_actions_mask"][[0, 7]] = True
    ids = to_pysc2_layout(obs, "MoveToBeacon")["available_actions"]
    assert ids.tolist() == [0, 7]
    back = to_padded_layout(to_pysc2_layout(obs, "MoveToBeacon"), fmt)
    np.testing.assert_array_equal(back["available_actions_mask"], obs["available_actions_mask"])


def test_non_square_and_subset():
    fmt = ObservationFormat((80, 60), 32, screen_features=["player_relative", "selected"],
                            minimap_features=["camera"])
    spec = observation_spec(fmt)
    assert spec["feature_screen"].shape == (2, 60, 80)
    assert spec["feature_minimap"].shape == (1, 32, 32)
    assert [f.index for f in fmt.screen_layers] == [5, 7]


@pytest.mark.parametrize("kwargs, pattern", [
    ({"screen_size": 15}, r"screen_size must be in \[16, 256\].*got 15"),
    ({"minimap_size": 300}, r"minimap_size must be in \[16, 256\].*got 300"),
    ({"screen_features": ["nope"]}, "unknown screen layer 'nope'"),
    ({"max_units": 0}, "max_units must be a positive int"),
])
def test_bad_format(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        ObservationFormat(**kwargs)


def test_action_spec():
    spec = action_spec(84, (64, 48))
    assert spec.function.maximum == 572
    assert list(spec.screen.maximum) == [83, 83]
    assert list(spec.minimap.maximum) == [63, 47]
    assert spec.select_unit_id.maximum == 499
    assert spec.queued.maximum == 1
    for s in spec:
        s.validate(s.generate_value())


@pytest.mark.parametrize("name", ["Nope", "movetobeacon", None])
def test_unknown_map_lists_the_maps(name):
    allowed = (r"unknown map .*; the simulator has the mini-games \['BuildMarines', "
               r"'CollectMineralShards'.* and the ladder maps \['Acropolis', 'CyberForest'")
    with pytest.raises(ValueError, match=allowed):
        get_map(name)
    with pytest.raises(ValueError, match=allowed):
        make(name)


def test_the_functional_step_checks_its_action_while_tracing():
    sim = Simulator("MoveToBeacon")
    state, _ = jax.eval_shape(sim.reset, jax.random.PRNGKey(0))  # Traced: no compile.
    one = to_dense([FUNCTIONS.no_op()])
    jax.eval_shape(sim.step, state, jax.tree_util.tree_map(lambda x: x[0], one))
    with pytest.raises(ValueError, match=r"action.function has shape \(2,\); expected "
                                         r"\(\): .*jax.vmap them for a batch"):
        jax.eval_shape(sim.step, state, to_dense([FUNCTIONS.no_op()] * 2))
    floats = jax.tree_util.tree_map(lambda x: x[0].astype(np.float32), one)
    with pytest.raises(ValueError, match="action.function has dtype float32"):
        jax.eval_shape(sim.act, state, floats)
