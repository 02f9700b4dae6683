"""Raw FullyConv: it reads the raw interface's observations, and its actions play the
simulator's raw environments."""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.functions import RAW_FUNCTIONS
from sc2jax.environment.interface.observation_tables import FeatureUnit as FU
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.networks import NetworkSpec, act, make_network, raw_policy
from sc2jax.networks.raw_fully_conv import scatter_units

RAW = ObservationFormat(screen_size=16, minimap_size=16,
                        screen_features=("player_relative",),
                        minimap_features=("player_relative", "camera"), use_raw_units=True,
                        max_units=8, raw_resolution=16, action_space="raw")


@functools.cache
def _setup():
    sim = Simulator("MoveToBeacon", RAW, use_slot_sizes=False)
    network = make_network("raw_fullyconv", RAW)
    states, ts = jax.jit(jax.vmap(sim.reset))(jax.random.split(jax.random.PRNGKey(0), 2))
    params = network.init(jax.random.PRNGKey(1), ts.observation)
    return sim, network, params, states, ts.observation


def test_outputs_read_the_unit_rows():
    _, network, params, _, obs = _setup()
    out = jax.jit(network.apply)(params, obs)
    assert out.function_logits.shape == (2, len(RAW_FUNCTIONS))
    assert out.world.logits.shape == (2, 16 * 16) and out.world.width == 16
    assert out.queued.shape == (2, 2) and out.units.shape == out.target.shape == (2, 8)
    rows = np.asarray(obs["raw_units"])
    # The marine is the player's; the beacon a real unit it does not own.
    np.testing.assert_array_equal(out.own, (rows[..., FU.alliance] == 1)
                                  & (rows[..., FU.unit_type] != 0))
    np.testing.assert_array_equal(out.real, rows[..., FU.unit_type] != 0)
    assert np.asarray(out.own).sum(1).tolist() == [1, 1]
    assert np.asarray(out.real).sum(1).tolist() == [2, 2]
    assert np.isfinite(np.asarray(out.world.logits)).all()


@pytest.mark.slow  # 6 s (the raw environment's step); test_raw_agent plays it too.
def test_sampled_actions_play_the_raw_environment():
    sim, network, params, states, obs = _setup()
    step = jax.jit(jax.vmap(sim.step))
    sample = jax.jit(lambda p, k, o: act(network, p, k, o))
    key = jax.random.PRNGKey(2)
    functions = set()
    for _ in range(12):
        key, k = jax.random.split(key)
        action, out = sample(params, k, obs)
        functions |= set(np.asarray(action.function).tolist())
        assert np.asarray(obs["available_actions_mask"])[np.arange(2), action.function].all()
        assert not np.asarray(action.units & ~out.own).any()
        states, ts = step(states, action)
        obs = ts.observation
    assert len(functions) > 2  # Moves and attacks beside no_op.


def test_scatter_sums_each_unit_into_its_pixel():
    rows = np.zeros((1, 3, len(FU)), np.int32)
    rows[0, :, FU.x], rows[0, :, FU.y] = (2, 2, 0), (1, 1, 3)
    encoding = jnp.asarray([[[1.0, 0.0], [2.0, 1.0], [5.0, 5.0]]])
    grid = scatter_units(encoding, jnp.asarray(rows), jnp.asarray([[True, True, False]]),
                         (4, 4))
    assert grid.shape == (1, 4, 4, 2)
    np.testing.assert_array_equal(grid[0, 1, 2], [3.0, 1.0])  # Two units at (2, 1).
    assert float(jnp.sum(grid)) == 4.0  # The padding row is not drawn.


def test_a_network_takes_only_its_own_action_space():
    features = dataclasses.replace(RAW, action_space="features", raw_resolution=None)
    with pytest.raises(ValueError, match="network 'fullyconv' does not take the 'raw' action"):
        make_network("fullyconv", RAW)
    with pytest.raises(ValueError, match="'raw_fullyconv' does not take the 'features'"):
        make_network("raw_fullyconv", features)
    with pytest.raises(ValueError, match="a raw network needs the format's raw_resolution"):
        NetworkSpec.from_format(dataclasses.replace(RAW, raw_resolution=None))
    spec = NetworkSpec.from_format(RAW)
    assert spec.num_functions == len(RAW_FUNCTIONS)
    assert spec.argument_sizes == ((16, 16), (2,), (8,), (8,))
    assert raw_policy.RAW_ARGS_MASK.shape == (spec.num_functions, len(spec.argument_sizes))
