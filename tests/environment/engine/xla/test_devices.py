"""`over_devices`, and the batched dm_env wrapper over it: environments split over the two
host devices that tests/conftest.py makes."""

import os
import subprocess
import sys

import jax
import numpy as np
import pytest

from sc2jax.environment import DenseAction, make
from sc2jax.environment import sc2_env as environments
from sc2jax.environment.agents import random_action
from sc2jax.environment.engine.xla.devices import (
    compile_small_loops_whole,
    device_sets,
    over_devices,
)
from tests.environment.helpers import PARAMS, SMALL_MAKE, small_sim

NUM_ENVS = 4


def _play(devices, steps: int = 3):
    """Random play of NUM_ENVS environments from distinct resets, split over `devices`
    (the batched wrapper's programs, `environments.compiled`, so the two tests of the
    split share their compilation); returns the last (states, timesteps)."""
    sim = small_sim("MoveToBeacon")
    reset, step = environments.compiled(sim, True, tuple(devices))
    state, ts = reset(jax.random.split(jax.random.PRNGKey(3), NUM_ENVS), PARAMS)
    act = jax.jit(jax.vmap(random_action, in_axes=(0, 0, None)), static_argnums=2)
    for i in range(steps):
        keys = jax.random.split(jax.random.PRNGKey(i), NUM_ENVS)
        # On the host, as the wrapper's actions come (an action left split over the
        # devices would be another program's argument).
        action = jax.device_get(act(keys, ts.observation["available_actions_mask"], sim.fmt.types))
        state, ts = step(state, action, PARAMS)
    return state, ts


@pytest.mark.slow
def test_two_devices_step_each_environment_as_one_device_does():
    devices = jax.devices()
    assert len(devices) >= 2, "tests/conftest.py gives the CPU two host devices"
    one = jax.device_get(_play(devices[:1]))
    two = _play(devices[:2])
    # The results stay split: each device holds its half of the environments.
    placed = two[0].units.pos.sharding
    assert placed.device_set == set(devices[:2])
    assert {s.data.shape[0] for s in two[0].units.pos.addressable_shards} == {NUM_ENVS // 2}
    two = jax.device_get(two)
    for (path, a), b in zip(jax.tree_util.tree_leaves_with_path(one), jax.tree.leaves(two)):
        if np.issubdtype(a.dtype, np.floating):
            # XLA compiles the halves' program for 2 environments, whose fusions can round
            # differently.
            np.testing.assert_allclose(a, b, atol=1e-4, err_msg=jax.tree_util.keystr(path))
        else:
            np.testing.assert_array_equal(a, b, err_msg=jax.tree_util.keystr(path))
    # The environments differ from one another, so a mix-up of halves would show.
    assert len({tuple(p.ravel()) for p in one[0].units.pos}) == NUM_ENVS


def test_one_device_returns_the_function_itself():
    def fn(x):
        return x
    assert over_devices(fn, jax.devices()[:1]) is fn


def test_bad_batches_are_refused_before_any_computation():
    split = over_devices(lambda tree: tree, jax.devices()[:2])
    with pytest.raises(ValueError, match=r"multiple of 2.*\['b'\] has shape \(3, 5\)"):
        split({"a": np.zeros((4, 5)), "b": np.zeros((3, 5))})
    with pytest.raises(ValueError, match=r"shape \(\)"):
        split(np.float32(1.0))
    with pytest.raises(ValueError, match="at least one device"):
        over_devices(lambda tree: tree, [])


def test_device_sets_split_what_divides_and_drop_repeats():
    local = jax.local_devices()
    assert len(local) == 2
    assert device_sets(64, [1, 0]) == [local[:1], local]
    assert device_sets(64, [2, 0, 1]) == [local, local[:1]]
    # One environment cannot be split: both counts give the one device.
    assert device_sets(1, [1, 2]) == [local[:1]]


def test_device_sets_refuse_more_devices_than_there_are():
    with pytest.raises(ValueError, match="3 devices asked for, but this process has 2"):
        device_sets(64, [3])


def _wrapper_episode(num_devices: int, steps: int = 5):
    """The batched dm_env wrapper's timesteps over `steps` random steps (episodes of 2
    steps, so environments auto-reset); the same actions on any device count."""
    env = make("MoveToBeacon", num_envs=NUM_ENVS, seed=5, game_steps_per_episode=16,
               num_devices=num_devices, **SMALL_MAKE)
    act = jax.jit(jax.vmap(random_action, in_axes=(0, 0, None)), static_argnums=2)
    timesteps = [env.reset()]
    for i in range(steps):
        keys = jax.random.split(jax.random.PRNGKey(i), NUM_ENVS)
        action = act(keys, timesteps[-1].observation["available_actions_mask"],
                     env.simulator.fmt.types)
        timesteps.append(env.step(DenseAction(*jax.device_get(action))))
    return env, timesteps


@pytest.mark.slow  # About 15-20 s on 2 cores: the fast tier stays under 3 minutes.
def test_batched_wrapper_split_over_two_devices_plays_as_one_device_does():
    two_env, two = _wrapper_episode(num_devices=2)
    assert two_env._state.units.pos.sharding.device_set == set(jax.devices()[:2])
    _, one = _wrapper_episode(num_devices=1)
    assert [list(ts.step_type) for ts in two] == [list(ts.step_type) for ts in one]
    assert {int(t) for ts in one for t in ts.step_type} == {0, 1, 2}  # auto-reset seen
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a.reward, b.reward)
        for key, value in a.observation.items():
            assert np.array_equal(value, b.observation[key]), key


def test_batched_wrapper_refuses_bad_device_counts_before_compiling():
    with pytest.raises(ValueError, match=r"num_devices must be an int in 0\.\.2.*got 3"):
        make("MoveToBeacon", num_envs=4, num_devices=3, **SMALL_MAKE)
    with pytest.raises(ValueError, match="num_envs=3 does not split evenly over 2 devices"):
        make("MoveToBeacon", num_envs=3, num_devices=0, **SMALL_MAKE)
    with pytest.raises(ValueError, match="num_devices=2 splits a batch.*num_envs=None"):
        make("MoveToBeacon", num_devices=2, **SMALL_MAKE)


_SMALL_LOOPS = """
import os, jax
from sc2jax.environment.engine.xla.devices import compile_small_loops_whole
compile_small_loops_whole(4096)
print(os.environ["XLA_FLAGS"])
compile_small_loops_whole(8192)  # Already set: kept.
print(os.environ["XLA_FLAGS"])
jax.numpy.ones(2).block_until_ready()
try:
    compile_small_loops_whole(4096)
except RuntimeError as e:
    print("refused:", e)
"""


def test_compile_small_loops_whole_sets_the_flag_only_before_the_backends_start():
    env = dict(os.environ, XLA_FLAGS="--xla_backend_extra_options=xla_cpu_enable_fast_min_max=true")
    out = subprocess.run([sys.executable, "-c", _SMALL_LOOPS], env=env, capture_output=True,
                         text=True, check=True).stdout.splitlines()
    flags = ("--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=4096,"
             "xla_cpu_enable_fast_min_max=true")
    assert out[:2] == [flags, flags]
    assert out[2].startswith("refused: compile_small_loops_whole must be called before")


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "1000"])
def test_compile_small_loops_whole_refuses_bad_sizes(bad):
    with pytest.raises(ValueError, match="max_bytes must be a positive int"):
        compile_small_loops_whole(bad)
