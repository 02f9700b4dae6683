"""The simulator benchmark's rollout at one environment runs the step unbatched (as a
single environment does), with the same results as a `vmap` of one."""

from unittest import mock

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import ObservationFormat, Simulator
from sc2jax.experiments.benchmarking import rollouts


def _vmapped(fn, num_envs, in_axes=0, out_axes=0):
    return jax.vmap(fn, in_axes=in_axes, out_axes=out_axes)


def test_per_env_of_one_runs_unbatched():
    # A switch, an argument without the environment axis, out_axes=1.
    def fn(x, k):
        return jnp.stack([jax.lax.switch(x[0] % 3, [lambda: k, lambda: -k, lambda: 2 * k]),
                          x[1] * k])

    x, k = jnp.array([[5, 7]]), jnp.float32(1.5)
    one = rollouts.per_env(fn, 1, in_axes=(0, None), out_axes=1)(x, k)
    assert one.shape == (2, 1), one.shape
    np.testing.assert_array_equal(one, _vmapped(fn, 1, (0, None), 1)(x, k))
    # Unbatched, the switch is a cond that runs one branch; vmapped, all and a select.
    assert "cond" in str(jax.make_jaxpr(rollouts.per_env(fn, 1, (0, None)))(x, k))
    assert "cond" not in str(jax.make_jaxpr(_vmapped(fn, 1, (0, None)))(x, k))


@pytest.mark.slow
def test_one_environment_rollout_matches_a_vmap_of_one():
    # Every leaf of the carry the same, bit for bit, after 12 steps.
    sim = Simulator(map_name="FindAndDefeatZerglings",
                    fmt=ObservationFormat(screen_size=16, minimap_size=16))
    rollout, carry = rollouts.sc2jax_rollout(sim, 1, 12)
    with mock.patch.object(rollouts, "per_env", _vmapped):
        plain, plain_carry = rollouts.sc2jax_rollout(sim, 1, 12)
    a, b = rollout(carry), plain(plain_carry)
    for u, v in zip(jax.tree.leaves(a), jax.tree.leaves(b)):
        assert u.shape == v.shape and u.dtype == v.dtype, (u.shape, v.shape)
        np.testing.assert_array_equal(u, v)
