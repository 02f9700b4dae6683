"""PySC2's raw interface through `make`: `action_space="raw"` environments take raw
function calls naming `raw_units` rows or tags, and observe as PySC2's raw agents do."""

import numpy as np
import pytest

from sc2jax.environment import make
from sc2jax.environment.interface.functions import FUNCTIONS, RAW_FUNCTIONS
from sc2jax.environment.interface.observation_tables import FeatureUnit as FU
from sc2jax.environment.interface.raw import RawAction, raw_zeros
from sc2jax.environment.sc2api.game_env import Bot

RAW = dict(screen_size=16, minimap_size=16, use_raw_units=True, max_units=8,
           action_space="raw", use_slot_sizes=False)


def _marine_row(raw_units):
    return int(np.flatnonzero(raw_units[:, FU.alliance] == 1)[0])


@pytest.mark.slow
def test_a_raw_environment_moves_a_unit_named_by_its_row():
    env = make("MoveToBeacon", seed=3, **RAW)
    assert isinstance(env.action_spec(), RawAction)
    assert env.action_spec().world.maximum.tolist() == [63, 63]  # The 64 x 64 map.
    ts = env.reset()
    assert "available_actions" not in ts.observation
    assert "available_actions" not in env.observation_spec()
    raw_units = ts.observation["raw_units"]
    row = _marine_row(raw_units)
    start = raw_units[row, [FU.x, FU.y]]
    goal = (int(start[0]) + 4, int(start[1]))
    for _ in range(6):
        ts = env.step(RAW_FUNCTIONS.Move_pt("now", [row], goal))
        row = _marine_row(ts.observation["raw_units"])
    marine = ts.observation["raw_units"][row]
    assert marine[FU.x] > start[0]
    assert ts.observation["last_actions"].size == 0  # As PySC2 gives raw agents.
    assert ts.observation["action_result"].size == 0
    with pytest.raises(ValueError, match="unit tag 77 is neither a row"):
        env.step(RAW_FUNCTIONS.Stop_quick("now", [77]))
    with pytest.raises(TypeError, match="takes a RawAction or a FunctionCall of RAW_FUNCTIONS"):
        env.step(np.zeros(3))


@pytest.mark.slow
def test_a_batch_of_raw_environments_takes_calls_or_a_raw_action():
    env = make("MoveToBeacon", num_envs=2, seed=1, **RAW)
    ts = env.reset()
    rows = [_marine_row(units) for units in ts.observation["raw_units"]]
    ts = env.step([RAW_FUNCTIONS.Move_pt("queued", [rows[0]], (30, 30)),
                   RAW_FUNCTIONS.no_op()])
    assert ts.observation["raw_units"].shape == (2, 8, len(FU))
    noop = raw_zeros(8, (2,))
    ts = env.step(noop)
    with pytest.raises(ValueError, match=r"action.function has values outside 0..563: \[600\]"):
        env.step(noop._replace(function=np.array([0, 600], np.int32)))
    with pytest.raises(ValueError, match=r"action.units has shape \(2, 3\); expected \(2, 8\)"):
        env.step(noop._replace(units=np.zeros((2, 3), bool)))
    with pytest.raises(ValueError, match="expected 2 FunctionCalls, got 1"):
        env.step([RAW_FUNCTIONS.no_op()])


def test_raw_settings_are_checked_before_anything_is_compiled():
    with pytest.raises(ValueError, match="action_space='raw' needs use_raw_units=True"):
        make("MoveToBeacon", action_space="raw")
    with pytest.raises(ValueError, match=r"action_space must be one of \('features', 'raw'\), "
                                         "got 'rgb'"):
        make("MoveToBeacon", action_space="rgb")
    with pytest.raises(ValueError, match="raw_resolution must be in"):
        make("MoveToBeacon", use_raw_units=True, raw_resolution=0)
    with pytest.raises(ValueError, match="backend 'sc2' takes the feature action space"):
        make("MoveToBeacon", backend="sc2", use_raw_units=True, action_space="raw")
    with pytest.raises(ValueError, match="bot plays the other player of a ladder map"):
        make("MoveToBeacon", bot=Bot("terran", "easy"))
    with pytest.raises(ValueError, match=r"the simulator's computer is a Terran \(race "
                                         r"'terran' or 'random'\) of build 'random'; got "
                                         "race 'zerg'"):
        make("Acropolis", bot=Bot("zerg", "easy"))
    with pytest.raises(ValueError, match="computer plays difficulties"):
        make("Acropolis", bot=Bot("terran", "cheat_insane", "random"))


def test_the_feature_interface_keeps_available_actions():
    env = make("MoveToBeacon", screen_size=16, minimap_size=16, use_slot_sizes=False)
    ts = env.reset()
    assert FUNCTIONS.no_op.id in ts.observation["available_actions"]
