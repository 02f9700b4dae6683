"""`Simulator.step(..., previous=...)`: observations written into the last one's buffers
are the same observations, and only the layers that cannot change are kept."""

import functools

import jax
import numpy as np
import pytest

from sc2jax.environment import EnvParams, ObservationFormat
from tests.environment.helpers import PARAMS, compiled, map_params, random_actor, small_sim

# Episodes truncated after 3 agent steps, so the runs below cross two auto-resets.
SHORT = EnvParams(game_steps_per_episode=np.int32(24))


@functools.cache
def step_into(sim):
    return jax.jit(lambda state, action, params, obs: sim.step(state, action, params,
                                                                previous=obs))


def play_both(sim, seed: int, steps: int, start=None):
    """Random play stepped with and without `previous` from the same reset and actions.

    Args:
      start: None, or a function of the reset's observation giving the first `previous`.

    Returns:
      A list of (observation without previous, observation with it), numpy.
    """
    reset, step = compiled(sim)
    act = random_actor(sim.fmt.types)
    key = jax.random.PRNGKey(seed)
    state, ts = reset(key, SHORT)
    state_into, obs_into = state, ts.observation if start is None else start(ts.observation)
    pairs = []
    for _ in range(steps):
        key, k = jax.random.split(key)
        action = act(k, ts.observation["available_actions_mask"])
        state, ts = step(state, action, SHORT)
        state_into, ts_into = step_into(sim)(state_into, action, SHORT, obs_into)
        obs_into = ts_into.observation
        pairs.append(jax.device_get((ts.observation, obs_into)))
    return pairs


@pytest.mark.parametrize("map_name",
                         map_params(["FindAndDefeatZerglings", "CollectMineralsAndGas"]))
def test_observations_written_into_the_last_are_the_same(map_name):
    # FindAndDefeatZerglings: fog, a moving camera, zero layers; CollectMineralsAndGas: an
    # economy map on slot sizes, with build progress.
    sim = small_sim(map_name)
    for plain, into in play_both(sim, seed=3, steps=8):
        assert plain.keys() == into.keys()
        for key in plain:
            np.testing.assert_array_equal(into[key], plain[key], err_msg=key)


# map -> (screen layers kept, screen layers written, minimap kept, minimap written).
KEPT = {
    # The flat maps' height is zero everywhere: kept, though the camera moves.
    "FindAndDefeatZerglings": ({"creep", "unit_energy", "effects", "build_progress",
                                "height_map"},
                               {"pathable", "visibility_map", "player_relative"},
                               {"height_map", "pathable", "buildable", "alerts"},
                               {"visibility_map", "camera", "selected"}),
    # No fog: the minimap's visibility is the revealed playable area.
    "MoveToBeacon": ({"creep", "unit_shields", "placeholder"},
                     {"visibility_map", "unit_type", "pathable"},
                     {"height_map", "visibility_map", "creep"},
                     {"camera", "player_relative"}),
}


# FindAndDefeatZerglings in the slow tier (8 s; its step is the slow tier's already).
@pytest.mark.parametrize("map_name", [pytest.param(m, marks=pytest.mark.slow)
                                      if m == "FindAndDefeatZerglings" else m
                                      for m in sorted(KEPT)])
def test_only_layers_that_cannot_change_are_kept(map_name):
    sim = small_sim(map_name)
    garbage = -7

    def start(obs):  # Every layer of the first `previous` holds garbage.
        return {**obs, "feature_screen": np.full_like(obs["feature_screen"], garbage),
                "feature_minimap": np.full_like(obs["feature_minimap"], garbage)}

    pairs = play_both(sim, seed=5, steps=6, start=start)
    for key, layers in (("feature_screen", sim.fmt.screen_layers),
                        ("feature_minimap", sim.fmt.minimap_layers)):
        plain = np.stack([p[key] for p, _ in pairs])  # [steps, layers, H, W]
        into = np.stack([q[key] for _, q in pairs])
        kept = {f.name for i, f in enumerate(layers) if np.all(into[:, i] == garbage)}
        written = [i for i, f in enumerate(layers) if f.name not in kept]
        np.testing.assert_array_equal(into[:, written], plain[:, written])
        # A kept layer is one the map's every observation has alike.
        for i, f in enumerate(layers):
            if f.name in kept:
                assert np.all(plain[:, i] == plain[:1, i]), (key, f.name)
        must_keep, must_write = KEPT[map_name][:2] if key == "feature_screen" else \
            KEPT[map_name][2:]
        assert must_keep <= kept and not kept & must_write, (key, kept)


@pytest.mark.parametrize("key,shape", [("feature_screen", (27, 32, 31)),
                                       ("feature_minimap", (2, 11, 32, 32))])
def test_previous_of_another_shape_is_refused(key, shape):
    sim = small_sim("MoveToBeacon")
    state, ts = compiled(sim)[0](jax.random.PRNGKey(0), PARAMS)
    action = random_actor(sim.fmt.types)(jax.random.PRNGKey(1),
                                         ts.observation["available_actions_mask"])
    previous = {**ts.observation, key: np.zeros(shape, np.int32)}
    with pytest.raises(ValueError, match=rf"previous\['{key}'\] must be int32"):
        sim.step(state, action, previous=previous)
    with pytest.raises(ValueError, match="previous"):
        sim.observe(state, previous={})


@pytest.mark.slow
def test_a_subset_of_layers_written_into_the_last():
    fmt = ObservationFormat(screen_size=24, minimap_size=16,
                            screen_features=("creep", "selected", "height_map"),
                            minimap_features=("buildable", "visibility_map", "camera"))
    for plain, into in play_both(small_sim("MoveToBeacon", fmt), seed=2, steps=4):
        for key in ("feature_screen", "feature_minimap"):
            np.testing.assert_array_equal(into[key], plain[key], err_msg=key)
