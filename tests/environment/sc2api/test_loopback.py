"""Over loopback, a `GameEnv` driving the simulator's SC2-API server sees the in-process
`SC2Env`'s episodes bit for bit: the same observations (unit lists included), rewards,
discounts and step types for the same seed and actions, on the mini-games.

DefeatRoaches and BuildMarines are left out (each 45-55 s of a 2-core suite): the
server's paths for them are DefeatZerglingsAndBanelings' (waves, combat on the leading
slots, and more: the banelings' bursts) and CollectMineralsAndGas' (production on the
leading slots, every Terran card), and the map scripts are the simulator's, which the
contract tests play."""

import jax
import numpy as np
import pytest

from sc2jax.environment import make
from sc2jax.environment.agents.random_agent import random_action
from sc2jax.environment.engine.minigames import MAPS
from sc2jax.environment.interface.dense import from_dense
from sc2jax.environment.interface.layout import available_mask
from sc2jax.environment.sc2api.controller import Controller
from sc2jax.environment.sc2api.game_env import GameEnv
from tests.environment.helpers import SMALL_MAKE

# The contract tests' environments (on every slot: their programs are shared); the server
# runs the same format on the slots in use, as by default, and must play the same game.
SIZES = dict(screen_size=32, minimap_size=32)
UNITS = dict(use_feature_units=True, use_raw_units=True)
ALL_SLOTS = dict(use_slot_sizes=False)
assert SMALL_MAKE == {**SIZES, **UNITS, **ALL_SLOTS}


def _assert_same(local, remote, where):
    for field in ("step_type", "reward", "discount"):
        assert getattr(local, field) == getattr(remote, field), (where, field)
    assert local.observation.keys() == remote.observation.keys()
    for key, value in local.observation.items():
        other = remote.observation[key]
        if key == "map_name":
            assert value == other
            continue
        assert value.dtype == other.dtype and value.shape == other.shape, (where, key)
        np.testing.assert_array_equal(value, other, err_msg=f"{where}: {key}")


def _loopback(server, map_name, steps, **options):
    local = make(map_name, seed=7, **SIZES, **ALL_SLOTS, **options)
    remote = GameEnv(lambda: Controller.connect("127.0.0.1", server.port), map_name,
                     random_seed=7, **SIZES, **options)
    key = jax.random.PRNGKey(3)
    a, b = local.reset(), remote.reset()
    kinds = set()
    try:
        for t in range(steps):
            _assert_same(a, b, f"{map_name} step {t}")
            kinds.add((int(a.step_type), a.discount))
            key, sub = jax.random.split(key)
            available = available_mask(a.observation["available_actions"])
            call = from_dense(random_action(sub, available, local.simulator.fmt.types))
            a, b = local.step(call), remote.step(call)
    finally:
        remote.close()
    return kinds


@pytest.mark.slow
def test_move_to_beacon_over_the_api_is_the_simulator_bit_for_bit(server):
    # 250 steps pass the 120 s timer: the game ends (player_result, discount 0) and
    # restarts.
    kinds = _loopback(server, "MoveToBeacon", 250, **UNITS)
    assert (2, 0.0) in kinds and (0, 0.0) in kinds


@pytest.mark.slow  # The fast tier keeps MoveToBeacon's whole episode over the API.
@pytest.mark.parametrize("map_name", sorted(set(MAPS) - {"MoveToBeacon", "DefeatRoaches",
                                                         "BuildMarines"}))
def test_the_mini_games_over_the_api_are_the_simulator_bit_for_bit(server, map_name):
    # Truncated episodes (LAST with the discount kept) and restarts, 3 episodes.
    kinds = _loopback(server, map_name, 45, game_steps_per_episode=160, **UNITS)
    assert (2, 1.0) in kinds


