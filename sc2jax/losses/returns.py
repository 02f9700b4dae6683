"""Bootstrapped returns for the n-step actor-critic (paper §4.1).

A3C (Mnih et al. 2016) acts for K steps (K = 40 in the paper), then bootstraps every
step of the segment from the value of the last observation:

    G_t = r_t + discount_t * G_{t+1},   G_T = v(s_T),

that is G_t = Σ_{k=0}^{T-t-1} (Π_{j<k} discount_{t+j}) r_{t+k} + (Π_{j<T-t} discount_{t+j}) v(s_T),
the paper's n-step return with n = T - t. `discount_t` is γ on ordinary steps and 0
at terminations, so nothing flows across an episode's end. Indices follow rlax: r_t
and discount_t are the reward and discount received after the action at step t.
"""

from __future__ import annotations

import chex
import jax
import jax.numpy as jnp
import rlax


def truncated_returns(r_t: chex.Array, discount_t: chex.Array,
                      bootstrap_value: chex.Numeric) -> chex.Array:
    """A3C's returns of a K-step segment, bootstrapped from its last observation.

    Args:
      r_t: [T] rewards.
      discount_t: [T] discounts (γ, or 0 at terminations).
      bootstrap_value: [] v(s_T), the value of the observation after the segment.

    Returns:
      [T] returns G_t = r_t + discount_t * G_{t+1}, G_T = bootstrap_value.
    """
    chex.assert_rank([r_t, discount_t, bootstrap_value], [1, 1, 0])
    chex.assert_equal_shape([r_t, discount_t])
    chex.assert_type([r_t, discount_t], float)

    def backward(g_tp1, inputs):
        r, d = inputs
        g = r + d * g_tp1
        return g, g

    _, returns = jax.lax.scan(backward, jnp.asarray(bootstrap_value, r_t.dtype),
                              (r_t, discount_t), reverse=True)
    return returns


def n_step_returns(r_t: chex.Array, discount_t: chex.Array, v_t: chex.Array,
                   n: int) -> chex.Array:
    """Fixed-n bootstrapped returns (rlax.n_step_bootstrapped_returns, λ = 1).

    G_t = r_t + d_t r_{t+1} + ... + (d_t...d_{t+n-2}) r_{t+n-1} + (d_t...d_{t+n-1}) v_{t+n-1},
    truncated at the end of the sequence (bootstrapping from v_{T-1}).

    Args:
      r_t: [T] rewards.
      discount_t: [T] discounts.
      v_t: [T] values of the observation after each step (v(s_{t+1})).
      n: the number of steps.

    Returns:
      [T] returns.
    """
    chex.assert_rank([r_t, discount_t, v_t], 1)
    chex.assert_equal_shape([r_t, discount_t, v_t])
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be a positive int, got {n!r}")
    return rlax.n_step_bootstrapped_returns(r_t, discount_t, v_t, n)
