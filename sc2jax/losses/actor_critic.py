"""The paper's A3C loss (§4.1), its V-trace variant and PPO, for one trajectory.

The A3C gradient of the paper,

    (G_t - v(s_t)) ∇ log π(a_t|s_t) + β (G_t - v(s_t)) ∇ v(s_t) + η Σ_a π(a|s_t) log π(a|s_t),

is the negative gradient of the loss

    L = -Σ_t sg(G_t - v(s_t)) log π(a_t|s_t) + β Σ_t ½ (sg(G_t) - v(s_t))² - η Σ_t H_t,

(sg = stop-gradient) averaged over t here. log π(a_t|s_t) is the composite
log-probability (function id plus the arguments that function uses). The entropy is
an independent regulariser for the function id and for each argument type:
H_t = H(π(a⁰|s_t)) + Σ_{l used by a⁰_t} H(π(a^l|s_t)); arguments the taken function does
not use contribute nothing. η = 1e-3 by default; β = 0.5.

With V-trace (Espeholt et al. 2018, via `rlax.vtrace_td_error_and_advantage`) G_t is
replaced by the V-trace target v_s for the value, and the advantage by
ρ_t (r_t + discount_t v_{s+1} - v(s_t)), correcting for a behaviour policy that lags.

PPO (Schulman et al. 2017) instead clips the ratio π/μ in a surrogate objective, with
GAE advantages and value targets computed once per batch and held fixed over several
passes (`gae_targets`, `ppo_loss`).
"""

from __future__ import annotations

from typing import NamedTuple

import chex
import jax
import jax.numpy as jnp
import rlax

from sc2jax.losses.returns import truncated_returns


class ActorCriticLossOutput(NamedTuple):
    """The loss and its parts for one trajectory (scalars unless noted).

    Attributes:
      loss: policy_loss + β value_loss + entropy_loss.
      policy_loss: -mean_t sg(A_t) log π(a_t|s_t).
      value_loss: mean_t ½ (sg(target_t) - v(s_t))² (unweighted).
      entropy_loss: -η mean_t H_t (already weighted).
      advantage: [T] A_t (G_t - v(s_t) for A3C; the V-trace PG advantage).
      value_target: [T] G_t (A3C) or v_s (V-trace).
    """

    loss: chex.Array
    policy_loss: chex.Array
    value_loss: chex.Array
    entropy_loss: chex.Array
    advantage: chex.Array
    value_target: chex.Array


def entropy_regulariser(function_entropy_t: chex.Array, argument_entropy_t: chex.Array,
                        argument_used_t: chex.Array, function_weight: float,
                        argument_weight: float) -> chex.Array:
    """-mean_t [η_f H(a⁰) + η_a Σ_{l used} H(a^l)]: the weighted entropy loss.

    Args:
      function_entropy_t: [T] entropy of the masked function-id distribution.
      argument_entropy_t: [T, 13] entropy of each argument head.
      argument_used_t: [T, 13] bool, the argument types the taken function uses.
      function_weight: η for the function id.
      argument_weight: η for each argument.

    Returns:
      [] the entropy loss (unused arguments get no gradient).
    """
    chex.assert_rank([function_entropy_t, argument_entropy_t, argument_used_t], [1, 2, 2])
    chex.assert_equal_shape([argument_entropy_t, argument_used_t])
    arguments = jnp.sum(jnp.where(argument_used_t, argument_entropy_t, 0.0), axis=-1)
    return -jnp.mean(function_weight * function_entropy_t + argument_weight * arguments)


def _combine(log_pi_a_tm1, v_tm1, advantage, target, entropy_loss, value_weight):
    advantage = jax.lax.stop_gradient(advantage)
    target = jax.lax.stop_gradient(target)
    policy_loss = -jnp.mean(advantage * log_pi_a_tm1)
    value_loss = jnp.mean(0.5 * jnp.square(target - v_tm1))
    return ActorCriticLossOutput(policy_loss + value_weight * value_loss + entropy_loss,
                                 policy_loss, value_loss, entropy_loss, advantage, target)


def a3c_loss(v_tm1: chex.Array, log_pi_a_tm1: chex.Array, r_t: chex.Array,
             discount_t: chex.Array, bootstrap_value: chex.Numeric,
             function_entropy_tm1: chex.Array, argument_entropy_tm1: chex.Array,
             argument_used_tm1: chex.Array, *, value_weight: float = 0.5,
             entropy_weight: float = 1e-3,
             argument_entropy_weight: float | None = None) -> ActorCriticLossOutput:
    """The n-step advantage actor-critic loss of the paper, for one K-step trajectory.

    Args:
      v_tm1: [T] v(s_t) for the T observations the actions were taken at.
      log_pi_a_tm1: [T] composite log π(a_t|s_t) (`policy.log_prob(...).total`).
      r_t: [T] rewards after each action.
      discount_t: [T] γ, or 0 at terminations (and across episode boundaries).
      bootstrap_value: [] v(s_T), the value of the observation after the last step.
      function_entropy_tm1: [T] entropy of π(a⁰|s_t) under the availability mask.
      argument_entropy_tm1: [T, 13] entropy of each argument head.
      argument_used_tm1: [T, 13] bool, the argument types a⁰_t uses.
      value_weight: β.
      entropy_weight: η for the function id (1e-3 as in the paper).
      argument_entropy_weight: η for each argument; defaults to `entropy_weight`.

    Returns:
      `ActorCriticLossOutput`.
    """
    chex.assert_rank([v_tm1, log_pi_a_tm1, r_t, discount_t, bootstrap_value],
                     [1, 1, 1, 1, 0])
    chex.assert_equal_shape([v_tm1, log_pi_a_tm1, r_t, discount_t, function_entropy_tm1])
    returns = truncated_returns(r_t, discount_t, jax.lax.stop_gradient(bootstrap_value))
    entropy_loss = entropy_regulariser(
        function_entropy_tm1, argument_entropy_tm1, argument_used_tm1, entropy_weight,
        entropy_weight if argument_entropy_weight is None else argument_entropy_weight)
    return _combine(log_pi_a_tm1, v_tm1, returns - v_tm1, returns, entropy_loss, value_weight)


def vtrace_loss(v_tm1: chex.Array, log_pi_a_tm1: chex.Array, behaviour_log_pi_a_tm1: chex.Array,
                r_t: chex.Array, discount_t: chex.Array, bootstrap_value: chex.Numeric,
                function_entropy_tm1: chex.Array, argument_entropy_tm1: chex.Array,
                argument_used_tm1: chex.Array, *, value_weight: float = 0.5,
                entropy_weight: float = 1e-3, argument_entropy_weight: float | None = None,
                lambda_: float = 1.0, clip_rho_threshold: float = 1.0,
                clip_pg_rho_threshold: float = 1.0) -> ActorCriticLossOutput:
    """Actor-critic loss with V-trace off-policy correction (IMPALA), one trajectory.

    Args:
      v_tm1, log_pi_a_tm1, r_t, discount_t, bootstrap_value, function_entropy_tm1,
      argument_entropy_tm1, argument_used_tm1, value_weight, entropy_weight,
      argument_entropy_weight: as `a3c_loss`.
      behaviour_log_pi_a_tm1: [T] log μ(a_t|s_t) of the actor that acted.
      lambda_: V-trace λ.
      clip_rho_threshold: ρ̄ for the value targets.
      clip_pg_rho_threshold: ρ̄ for the policy-gradient advantage.

    Returns:
      `ActorCriticLossOutput` (advantage and value_target from V-trace).
    """
    chex.assert_rank([v_tm1, log_pi_a_tm1, behaviour_log_pi_a_tm1, r_t, discount_t,
                      bootstrap_value], [1, 1, 1, 1, 1, 0])
    chex.assert_equal_shape([v_tm1, log_pi_a_tm1, behaviour_log_pi_a_tm1, r_t, discount_t])
    rho_tm1 = jnp.exp(jax.lax.stop_gradient(log_pi_a_tm1) - behaviour_log_pi_a_tm1)
    v_t = jnp.concatenate([v_tm1[1:], jnp.reshape(bootstrap_value, (1,))])
    errors, pg_advantage, _ = rlax.vtrace_td_error_and_advantage(
        jax.lax.stop_gradient(v_tm1), jax.lax.stop_gradient(v_t), r_t, discount_t, rho_tm1,
        lambda_=lambda_, clip_rho_threshold=clip_rho_threshold,
        clip_pg_rho_threshold=clip_pg_rho_threshold)
    target = jax.lax.stop_gradient(v_tm1) + errors  # v_s
    entropy_loss = entropy_regulariser(
        function_entropy_tm1, argument_entropy_tm1, argument_used_tm1, entropy_weight,
        entropy_weight if argument_entropy_weight is None else argument_entropy_weight)
    return _combine(log_pi_a_tm1, v_tm1, pg_advantage, target, entropy_loss, value_weight)


def gae_targets(v_tm1: chex.Array, r_t: chex.Array, discount_t: chex.Array,
                bootstrap_value: chex.Numeric, lambda_: float = 0.95
                ) -> tuple[chex.Array, chex.Array]:
    """Generalised advantage estimates and value targets of one trajectory (GAE, Schulman
    et al. 2016), without gradients: what PPO holds fixed over its epochs.

    Args:
      v_tm1, r_t, discount_t, bootstrap_value: as `a3c_loss` ([T], [T], [T], []).
      lambda_: GAE's λ (1: the n-step returns of A3C; 0: one-step TD errors).

    Returns:
      (advantage [T], value target [T] = advantage + v(s_t)).
    """
    chex.assert_rank([v_tm1, r_t, discount_t, bootstrap_value], [1, 1, 1, 0])
    values = jax.lax.stop_gradient(jnp.concatenate([v_tm1, jnp.reshape(bootstrap_value, (1,))]))
    advantage = rlax.truncated_generalized_advantage_estimation(r_t, discount_t, lambda_,
                                                                values)
    return advantage, advantage + values[:-1]


def ppo_loss(v_tm1: chex.Array, log_pi_a_tm1: chex.Array, behaviour_log_pi_a_tm1: chex.Array,
             advantage_tm1: chex.Array, value_target_tm1: chex.Array,
             function_entropy_tm1: chex.Array, argument_entropy_tm1: chex.Array,
             argument_used_tm1: chex.Array, *, clip_epsilon: float = 0.2,
             value_weight: float = 0.5, entropy_weight: float = 1e-3,
             argument_entropy_weight: float | None = None) -> ActorCriticLossOutput:
    """PPO's clipped surrogate loss (Schulman et al. 2017) for one trajectory:
    -mean_t min(ρ_t A_t, clip(ρ_t, 1-ε, 1+ε) A_t) with ρ_t = π(a_t|s_t) / μ(a_t|s_t),
    plus the value and entropy terms of `a3c_loss`.

    Args:
      v_tm1, log_pi_a_tm1, function_entropy_tm1, argument_entropy_tm1,
      argument_used_tm1, value_weight, entropy_weight, argument_entropy_weight: as
        `a3c_loss`.
      behaviour_log_pi_a_tm1: [T] log μ(a_t|s_t) of the policy that acted.
      advantage_tm1, value_target_tm1: [T] fixed before the update (`gae_targets`).
      clip_epsilon: ε.

    Returns:
      `ActorCriticLossOutput`.
    """
    chex.assert_equal_shape([v_tm1, log_pi_a_tm1, behaviour_log_pi_a_tm1, advantage_tm1,
                             value_target_tm1, function_entropy_tm1])
    ratio = jnp.exp(log_pi_a_tm1 - behaviour_log_pi_a_tm1)
    advantage = jax.lax.stop_gradient(advantage_tm1)
    target = jax.lax.stop_gradient(value_target_tm1)
    policy_loss = rlax.clipped_surrogate_pg_loss(ratio, advantage, clip_epsilon)
    value_loss = jnp.mean(0.5 * jnp.square(target - v_tm1))
    entropy_loss = entropy_regulariser(
        function_entropy_tm1, argument_entropy_tm1, argument_used_tm1, entropy_weight,
        entropy_weight if argument_entropy_weight is None else argument_entropy_weight)
    return ActorCriticLossOutput(policy_loss + value_weight * value_loss + entropy_loss,
                                 policy_loss, value_loss, entropy_loss, advantage, target)
