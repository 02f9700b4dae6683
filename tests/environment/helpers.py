"""Shared test helpers: small simulators whose compiled functions every test shares.

`small_sim(name)` is the very `Simulator` that `make(name, **SMALL_MAKE)` uses, so the
dm_env wrappers, the functional API and the contract tests compile each map once.

Both run every unit slot (`use_slot_sizes=False`): the same game, compiled about three
times as fast on the maps with slot sizes (one copy of the game loop: DefeatRoaches'
step 4.2 s against 14.2 s, 2-core CPU, 2026-11-30). The tests of the leading slots ask
for them (`small_sim(..., sized=True)`), and the SC2-API server, training and the
commands run on them as by default.
"""

import functools

import jax
import numpy as np
import pytest

from sc2jax.environment import EnvParams, ObservationFormat, Simulator
from sc2jax.environment.agents import random_action
from sc2jax.environment.engine import compiled as compile_cache
from sc2jax.environment.engine.compiled import simulator

# The unit lists' default length (64), so that the SC2-API server's format for a client
# that asks for raw data is this one too, and the loopback tests share these programs.
SMALL_FORMAT = dict(screen_size=32, minimap_size=32, use_feature_units=True, use_raw_units=True)
SMALL = ObservationFormat(**SMALL_FORMAT)
SMALL_MAKE = dict(SMALL_FORMAT, use_slot_sizes=False)
PARAMS = EnvParams(game_steps_per_episode=np.int32(0))


def small_sim(map_name: str, fmt: ObservationFormat = SMALL, sized: bool = False) -> Simulator:
    return simulator(map_name, fmt, 8, 0, 1.0, 1.0, False, sized)


def compiled(sim: Simulator, batched: bool = False):
    """(reset(key, params), step(state, action, params)), jitted once per simulator."""
    return compile_cache.compiled(sim, batched)


def assert_trees_equal(a, b):
    """Asserts two pytrees of arrays have the same structure and equal leaves, bit for bit."""
    assert jax.tree_util.tree_structure(a) == jax.tree_util.tree_structure(b)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


@functools.cache
def random_actor(types):
    """A jitted random policy for one resolution: (key, available_actions) -> action."""
    return jax.jit(functools.partial(random_action, types=types))


def random_play(sim: Simulator, seed: int, steps: int, start_loop: int = 0):
    """Plays `steps` random steps (auto-resetting) from a reset with `seed`, its clock
    moved on to `start_loop` (to reach the end of a long map sooner).

    Yields:
      The reset's (state, timestep), then each step's (action, state, timestep).
    """
    reset, step = compiled(sim)
    act = random_actor(sim.fmt.types)
    key = jax.random.PRNGKey(seed)
    state, ts = reset(key, PARAMS)
    state = state.replace(game_loop=np.int32(start_loop))
    yield state, ts
    for _ in range(steps):
        key, k = jax.random.split(key)
        action = act(k, ts.observation["available_actions_mask"])
        state, ts = step(state, action, PARAMS)
        yield action, state, ts


def random_episode(sim: Simulator, seed: int, steps: int, start_loop: int = 0):
    """`random_play`'s timesteps and actions.

    Returns:
      (first timestep, list of timesteps, list of actions), all as numpy.
    """
    play = random_play(sim, seed, steps, start_loop)
    _, first = next(play)
    timesteps, actions = [], []
    for action, _, ts in play:
        timesteps.append(jax.device_get(ts))
        actions.append(jax.device_get(action))
    return jax.device_get(first), timesteps, actions


SLOW_MAPS = ("FindAndDefeatZerglings", "DefeatRoaches", "DefeatZerglingsAndBanelings",
             "CollectMineralsAndGas", "BuildMarines")
"""The maps whose programs take longest to compile: their contract tests are in the slow
tier (`pytest -m "not slow"` leaves them out; the full suite runs them). The fast tier
keeps MoveToBeacon and CollectMineralShards."""


def map_params(names):
    """`names` as parametrize values, those of `SLOW_MAPS` marked slow."""
    return [pytest.param(m, marks=pytest.mark.slow) if m in SLOW_MAPS else m for m in names]
