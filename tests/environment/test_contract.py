"""The contract every mini-game must meet: dm_env step types and discounts, spec
conformance of every observation, determinism, and jit/vmap consistency."""

import dm_env
import jax
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS, MAPS, ObservationFormat, make, to_dense
from sc2jax.environment.interface import narrow
from tests.environment.helpers import (
    PARAMS,
    SMALL_MAKE,
    compiled,
    map_params,
    random_episode,
    small_sim,
)

MAP_NAMES = sorted(MAPS)


def _stack(timesteps):
    return jax.tree_util.tree_map(lambda *xs: np.stack(xs), *timesteps)


@pytest.mark.parametrize("map_name", map_params(MAP_NAMES))
def test_episode_structure_and_specs(map_name):
    sim = small_sim(map_name)
    # Long maps start their clock within 120 steps of the end.
    start = max(0, sim.game.time_limit_loops - 120 * sim.step_mul)
    length = (sim.game.time_limit_loops - start) // sim.step_mul
    first, timesteps, _ = random_episode(sim, seed=3, steps=length + 2, start_loop=start)
    step_types = np.array([int(ts.step_type) for ts in timesteps])
    assert int(first.step_type) == dm_env.StepType.FIRST
    assert float(first.discount) == 0.0 and float(first.reward) == 0.0
    ended = np.flatnonzero(step_types == dm_env.StepType.LAST)
    assert ended.size >= 1
    last = ended[0]
    # Every step before LAST is MID; the step after LAST starts a new episode.
    assert (step_types[:last] == dm_env.StepType.MID).all()
    assert step_types[last + 1] == dm_env.StepType.FIRST
    assert float(timesteps[last].discount) == 0.0  # The episode ends with a player_result.
    assert all(float(ts.discount) == 1.0 for ts in timesteps[:last])
    assert float(timesteps[last + 1].reward) == 0.0
    game_loops = [int(ts.observation["game_loop"][0]) for ts in timesteps[:last + 1]]
    assert game_loops == [start + 8 * (i + 1) for i in range(last + 1)]
    if map_name in ("MoveToBeacon", "CollectMineralShards", "CollectMineralsAndGas",
                    "BuildMarines"):  # No defeat: the timer ends.
        assert last == length - 1
        assert game_loops[-1] == sim.game.time_limit_loops
    # Training trajectories keep the layers in bytes (`narrow`): exact on this episode.
    fmt = sim.fmt
    for key, features in zip(narrow.LAYER_KEYS, (fmt.screen_layers, fmt.minimap_layers)):
        layers = np.stack([np.asarray(ts.observation[key]) for ts in timesteps])
        np.testing.assert_array_equal(narrow.unpack(*narrow.pack(layers, features), features),
                                      layers, err_msg=key)
    # Every observation conforms to the padded spec.
    spec = sim.observation_spec()
    for obs in (first.observation, timesteps[last].observation,
                timesteps[last + 1].observation):
        assert set(obs) == set(spec)
        for key, s in spec.items():
            s.validate(np.asarray(obs[key]))


@pytest.mark.parametrize("map_name", map_params(MAP_NAMES))
def test_determinism(map_name):
    sim = small_sim(map_name)
    a = random_episode(sim, seed=11, steps=30)
    b = random_episode(sim, seed=11, steps=30)
    c = random_episode(sim, seed=12, steps=30)
    leaves_a, leaves_b = jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)
    assert len(leaves_a) == len(leaves_b)
    assert all(np.array_equal(x, y) for x, y in zip(leaves_a, leaves_b))
    screens = lambda run: np.stack([ts.observation["feature_screen"] for ts in run[1]])  # noqa: E731
    assert not np.array_equal(screens(a), screens(c))


@pytest.mark.parametrize("map_name", map_params(MAP_NAMES))
def test_step_keeps_avals(map_name):
    """A step returns arrays of the same shapes, dtypes and weak types as reset, so a
    jitted loop over it never recompiles."""
    sim = small_sim(map_name)
    reset, step = compiled(sim)
    state, ts = reset(jax.random.PRNGKey(0), PARAMS)
    state2, ts2 = step(state, to_dense(FUNCTIONS.no_op()), PARAMS)
    avals = lambda tree: [jax.typeof(x) for x in jax.tree_util.tree_leaves(tree)]  # noqa: E731
    assert avals((state, ts)) == avals((state2, ts2))


@pytest.mark.parametrize("map_name", map_params(MAP_NAMES))
def test_dm_env_wrapper_pysc2_layout(map_name):
    env = make(map_name, seed=1, **SMALL_MAKE)
    assert env.simulator is small_sim(map_name)  # Shares the compiled functions.
    spec = env.observation_spec()
    ts = env.reset()
    assert ts.step_type == dm_env.StepType.FIRST and ts.reward == 0.0 and ts.discount == 0.0
    for _ in range(3):
        for key, s in spec.items():
            s.validate(ts.observation[key])
        assert ts.observation["map_name"] == map_name
        ts = env.step(FUNCTIONS.select_army("select") if 7 in ts.observation[
            "available_actions"] else FUNCTIONS.no_op())
        assert ts.step_type == dm_env.StepType.MID
    # Truncation: PySC2's game_steps_per_episode ends the episode with the discount kept.
    env = make(map_name, seed=1, game_steps_per_episode=16, **SMALL_MAKE)
    env.reset()
    ts = env.step(FUNCTIONS.no_op())
    assert ts.mid()
    ts = env.step(FUNCTIONS.no_op())
    assert ts.last() and ts.discount == 1.0
    assert env.step(FUNCTIONS.no_op()).first()


def test_batched_wrapper_auto_reset():
    env = make("MoveToBeacon", num_envs=3, seed=0, game_steps_per_episode=8, **SMALL_MAKE)
    ts = env.reset()
    assert list(ts.step_type) == [0, 0, 0]
    assert ts.observation["feature_screen"].shape == (3, 27, 32, 32)
    ts = env.step([FUNCTIONS.no_op()] * 3)
    assert list(ts.step_type) == [2, 2, 2] and list(ts.discount) == [1.0] * 3
    ts = env.step(to_dense([FUNCTIONS.no_op()] * 3))
    assert list(ts.step_type) == [0, 0, 0]


def test_layer_subsets_render_identically():
    full = small_sim("CollectMineralShards")
    fmt = ObservationFormat(screen_size=32, minimap_size=32,
                            screen_features=("selected", "player_relative"),
                            minimap_features=("camera",))
    part = small_sim("CollectMineralShards", fmt)
    _, ts_full = compiled(full)[0](jax.random.PRNGKey(4), PARAMS)
    _, ts_part = compiled(part)[0](jax.random.PRNGKey(4), PARAMS)
    screen = np.asarray(ts_full.observation["feature_screen"])
    assert np.array_equal(ts_part.observation["feature_screen"], screen[[7, 5]])
    assert np.array_equal(ts_part.observation["feature_minimap"],
                          np.asarray(ts_full.observation["feature_minimap"])[[3]])
