"""FullyConv LSTM: unrolling equals stepping, and the carry resets at episode starts."""

import functools

import jax
import jax.numpy as jnp
import numpy as np

from tests.networks.helpers import BATCH, jitted_apply, network, seq_obs

T = 3


@functools.cache
def _unroll(first_key: tuple):
    """Outputs and final carry of a T=3 unroll from a zero carry (cached per `first`)."""
    net, params = network("fullyconv_lstm")
    first = jnp.asarray(first_key, bool)
    return jitted_apply("fullyconv_lstm")(params, net.initial_carry(BATCH), seq_obs(5, T), first)


def _close(a, b):
    return all(np.allclose(x, y, atol=1e-5) for x, y in zip(jax.tree.leaves(a),
                                                             jax.tree.leaves(b)))


def test_unroll_equals_step_by_step():
    net, params = network("fullyconv_lstm")
    obs = seq_obs(5, T)
    carry = net.initial_carry(BATCH)
    first = jnp.zeros((1, BATCH), bool)
    outs = []
    for t in range(T):  # T=1 unrolls share the contract test's compilation
        carry, out = jitted_apply("fullyconv_lstm")(
            params, carry, jax.tree.map(lambda x, t=t: x[t:t + 1], obs), first)
        outs.append(out)
    stepped = jax.tree.map(lambda *x: jnp.concatenate(x), *outs)
    carry_u, unrolled = _unroll(((False, False),) * T)
    assert _close(stepped, unrolled) and _close(carry, carry_u)


def test_carry_resets_at_episode_start():
    # Episode start at t = 2 in environment 0 only.
    first = ((False, False), (False, False), (True, False))
    _, reset = _unroll(first)
    _, no_reset = _unroll(((False, False),) * T)
    # Environment 0 at t = 2 equals a fresh start on s_2 alone: with the carry zeroed,
    # the history s_0, s_1 is forgotten. Environment 1 is untouched.
    net, params = network("fullyconv_lstm")
    _, fresh = jitted_apply("fullyconv_lstm")(
        params, net.initial_carry(BATCH), jax.tree.map(lambda x: x[2:3], seq_obs(5, T)),
        jnp.zeros((1, BATCH), bool))
    np.testing.assert_allclose(reset.value[2, 0], fresh.value[0, 0], atol=1e-5)
    np.testing.assert_allclose(reset.function_logits[2, 0], fresh.function_logits[0, 0],
                               atol=1e-5)
    assert not np.allclose(no_reset.value[2, 0], reset.value[2, 0], atol=1e-6)
    np.testing.assert_allclose(reset.value[:, 1], no_reset.value[:, 1], atol=1e-6)
    np.testing.assert_allclose(reset.value[:2], no_reset.value[:2], atol=1e-6)
