"""acme-style factory: a network and hyper-parameters -> `(params, batch) -> (loss, metrics)`.

The batch is a `Trajectory` of T steps for B environments (time-major). The network
runs on all T+1 observations; the last one only gives the bootstrap value v(s_T).
The per-trajectory loss (`a3c_loss`, `vtrace_loss` or `ppo_loss`) is vmapped over B and
averaged. PPO's advantages and value targets are computed once per batch, before its
passes over it (`make_ppo_targets`), and carried in the `Trajectory`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.raw import RawAction
from sc2jax.losses.actor_critic import a3c_loss, gae_targets, ppo_loss, vtrace_loss
from sc2jax.networks.outputs import LSTMCarry
from sc2jax.networks.raw_policy import policy_of
from sc2jax.networks.unroll import unroll

LossFn = Callable[[Any, "Trajectory"], tuple[jax.Array, dict[str, jax.Array]]]
OFF_POLICY_CORRECTIONS = ("none", "vtrace", "ppo")


class Trajectory(NamedTuple):
    """T steps of B environments, time-major.

    Attributes:
      observation: padded observations, leaves [T+1, B, ...] (s_0 .. s_T).
      action: `DenseAction` [T, B] taken at s_0 .. s_{T-1} (a `RawAction` for a raw
        network).
      reward: [T, B] float32 reward after each action.
      discount: [T, B] float32, γ, or 0 where the episode terminated.
      first: [T+1, B] bool, True where an observation starts an episode (resets the
        FullyConv LSTM carry; the return never bootstraps across it).
      behaviour_log_prob: [T, B] log μ(a_t|s_t) of the acting policy (V-trace, PPO).
      initial_carry: the FullyConv LSTM carry before s_0 (recurrent networks only).
      advantage, value_target: [T, B] PPO's, fixed before its passes
        (`make_ppo_targets`); None otherwise.
    """

    observation: Mapping[str, jax.Array]
    action: DenseAction | RawAction
    reward: jax.Array
    discount: jax.Array
    first: jax.Array
    behaviour_log_prob: jax.Array | None = None
    initial_carry: LSTMCarry | None = None
    advantage: jax.Array | None = None
    value_target: jax.Array | None = None


def _unroll(network: nn.Module, params: Any, batch: Trajectory):
    """The network's outputs at all T+1 observations (a dummy action at s_T, unused)."""
    action = jax.tree.map(lambda x: jnp.concatenate([x, jnp.zeros_like(x[:1])]),
                          batch.action)
    return unroll(network, params, batch.observation, action, batch.first,
                  batch.initial_carry)


def _discount(batch: Trajectory) -> jax.Array:
    """[T, B] γ_t, 0 before an episode start too: the return never bootstraps across one
    (termination or truncation)."""
    return batch.discount * (1.0 - batch.first[1:].astype(batch.discount.dtype))


def _scaled(batch: Trajectory, reward_scale: float) -> Trajectory:
    """The trajectory with its rewards multiplied by `reward_scale`."""
    return batch if reward_scale == 1.0 else batch._replace(reward=batch.reward * reward_scale)


def make_actor_critic_loss(network: nn.Module, *, value_weight: float = 0.5,
                           entropy_weight: float = 1e-3,
                           argument_entropy_weight: float | None = None,
                           off_policy_correction: str = "none", vtrace_lambda: float = 1.0,
                           clip_rho_threshold: float = 1.0,
                           clip_pg_rho_threshold: float = 1.0,
                           clip_epsilon: float = 0.2, reward_scale: float = 1.0) -> LossFn:
    """Builds the A3C (or V-trace) loss of a network.

    Args:
      network: one of the four networks.
      value_weight: β.
      entropy_weight: η for the function id (1e-3, the paper's).
      argument_entropy_weight: η per argument (default: `entropy_weight`).
      off_policy_correction: "none" (A3C n-step returns), "vtrace" or "ppo" (the
        clipped surrogate; the trajectory must carry `make_ppo_targets`' targets).
      vtrace_lambda, clip_rho_threshold, clip_pg_rho_threshold: V-trace settings.
      clip_epsilon: PPO's ε.
      reward_scale: multiplies the rewards (for PPO, give `make_ppo_targets` the same).

    Returns:
      `loss_fn(params, trajectory) -> (loss, metrics)`, jittable and differentiable.

    Raises:
      ValueError: for an unknown `off_policy_correction`.
    """
    if off_policy_correction not in OFF_POLICY_CORRECTIONS:
        raise ValueError(f"unknown off_policy_correction {off_policy_correction!r}; "
                         f"allowed: {list(OFF_POLICY_CORRECTIONS)}")
    weights = dict(value_weight=value_weight, entropy_weight=entropy_weight,
                   argument_entropy_weight=argument_entropy_weight)

    def loss_fn(params: Any, batch: Trajectory) -> tuple[jax.Array, dict[str, jax.Array]]:
        batch = _scaled(batch, reward_scale)
        t = jnp.shape(batch.reward)[0]
        out = _unroll(network, params, batch)
        out_tm1 = jax.tree.map(lambda x: x[:t], out)
        available = batch.observation["available_actions_mask"][:t]
        pi = policy_of(out_tm1)
        log_pi = pi.log_prob(out_tm1, batch.action, available).total
        ent = pi.entropy(out_tm1, available)
        arg_entropy = jnp.stack(ent.arguments, axis=-1)
        used = pi.used_arguments(batch.action.function)
        discount = _discount(batch)
        if off_policy_correction != "none" and batch.behaviour_log_prob is None:
            raise ValueError(f"{off_policy_correction} needs trajectory.behaviour_log_prob")
        if off_policy_correction == "ppo":
            if batch.advantage is None:
                raise ValueError("PPO needs the trajectory's advantage and value_target "
                                 "(make_ppo_targets)")
            per_env = jax.vmap(lambda *a: ppo_loss(*a, **weights, clip_epsilon=clip_epsilon),
                               in_axes=1)
            res = per_env(out.value[:t], log_pi, batch.behaviour_log_prob, batch.advantage,
                          batch.value_target, ent.function, arg_entropy, used)
        elif off_policy_correction == "vtrace":
            per_env = jax.vmap(lambda *a: vtrace_loss(
                *a, **weights, lambda_=vtrace_lambda, clip_rho_threshold=clip_rho_threshold,
                clip_pg_rho_threshold=clip_pg_rho_threshold), in_axes=(1, 1, 1, 1, 1, 0, 1, 1, 1))
            res = per_env(out.value[:t], log_pi, batch.behaviour_log_prob, batch.reward,
                          discount, out.value[t], ent.function, arg_entropy, used)
        else:
            per_env = jax.vmap(lambda *a: a3c_loss(*a, **weights),
                               in_axes=(1, 1, 1, 1, 0, 1, 1, 1))
            res = per_env(out.value[:t], log_pi, batch.reward, discount, out.value[t],
                          ent.function, arg_entropy, used)
        loss = jnp.mean(res.loss)
        metrics = {
            "loss": loss,
            "policy_loss": jnp.mean(res.policy_loss),
            "value_loss": jnp.mean(res.value_loss),
            "entropy_loss": jnp.mean(res.entropy_loss),
            "function_entropy": jnp.mean(ent.function),
            # The screen (raw: world) argument's entropy at every visited state, used or not.
            "screen_entropy": jnp.mean(ent.arguments[0]),
            "advantage": jnp.mean(res.advantage),
            "value": jnp.mean(out.value[:t]),
            "value_target": jnp.mean(res.value_target),
            "log_prob": jnp.mean(log_pi),
        }
        return loss, metrics

    return loss_fn


def make_ppo_targets(network: nn.Module, gae_lambda: float = 0.95, reward_scale: float = 1.0
                     ) -> Callable[[Any, Trajectory], Trajectory]:
    """`(params, trajectory) -> trajectory` with PPO's `advantage` and `value_target`
    (`gae_targets`) from the values of `params`, the parameters that acted, and the
    rewards multiplied by `reward_scale`."""

    def targets(params: Any, batch: Trajectory) -> Trajectory:
        t = jnp.shape(batch.reward)[0]
        value, discount = _unroll(network, params, batch).value, _discount(batch)
        advantage, target = jax.vmap(lambda *a: gae_targets(*a, lambda_=gae_lambda),
                                     in_axes=(1, 1, 1, 0), out_axes=1)(
            value[:t], _scaled(batch, reward_scale).reward, discount, value[t])
        return batch._replace(advantage=advantage, value_target=target)

    return targets
