"""Supervised learning from replays (paper §5): value and policy heads, Table 2 metrics.

Dual-headed networks predict the game outcome (1 = win vs 0 = loss or tie) and the
action the player took:

    L = value_weight * BCE(sigmoid(v(s)), outcome) - log π(a|s),

where `v(s)` (the network's value output) is the logit of P(win), and log π(a|s) is
the composite log-probability: the function id under the available-action mask plus
the arguments the target function takes (teacher-forced for arFullyConv).

Metrics are the paper's Table 2 columns, top-1 and top-5 accuracy for the action
(function id, masked), the screen argument and the minimap argument (over the
examples whose target function takes that argument), and the value accuracy.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import chex
import flax.linen as nn
import jax
import jax.numpy as jnp
import optax

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.networks import policy
from sc2jax.networks.outputs import NetworkOutput, PixelLogits, XYLogits

SCREEN, MINIMAP = 0, 1  # argument type ids


class SupervisedLossOutput(NamedTuple):
    """Scalars: loss = value_weight * value_loss + policy_loss (and its parts)."""

    loss: chex.Array
    value_loss: chex.Array
    policy_loss: chex.Array
    function_loss: chex.Array
    argument_loss: chex.Array


class SupervisedBatch(NamedTuple):
    """A batch of replay frames.

    Attributes:
      observation: padded observations [B, ...] (available_actions: the union over the
        frames of the step, as in the paper).
      action: the target `DenseAction` [B...] (no_op where the player did nothing).
      outcome: [B] float32, 1 for a win, 0 for a loss or a tie.
    """

    observation: Mapping[str, jax.Array]
    action: DenseAction
    outcome: jax.Array


def supervised_loss(output: NetworkOutput, target: DenseAction, available_actions: jax.Array,
                    outcome: jax.Array, *, value_weight: float = 1.0) -> SupervisedLossOutput:
    """The dual-headed supervised loss, averaged over the batch.

    Args:
      output: network output [B] (teacher-forced on `target` for arFullyConv).
      target: the player's `DenseAction` [B].
      available_actions: [B, F] bool mask.
      outcome: [B] 1 = win, 0 = loss or tie.
      value_weight: weight of the value loss against the policy loss.

    Returns:
      `SupervisedLossOutput`.
    """
    chex.assert_rank([output.value, outcome, available_actions], [1, 1, 2])
    chex.assert_equal_shape([output.value, outcome])
    lp = policy.log_prob(output, target, available_actions)
    value_loss = jnp.mean(optax.sigmoid_binary_cross_entropy(
        output.value, outcome.astype(output.value.dtype)))
    function_loss = -jnp.mean(lp.function)
    argument_loss = -jnp.mean(sum(lp.arguments))
    policy_loss = function_loss + argument_loss
    return SupervisedLossOutput(value_weight * value_loss + policy_loss, value_loss,
                                policy_loss, function_loss, argument_loss)


def _rank(scores: jax.Array, target: jax.Array) -> jax.Array:
    """How many entries of [B, n] scores beat the target's: 0 means top-1."""
    target_score = jnp.take_along_axis(scores, target[:, None], axis=-1)
    return jnp.sum(scores > target_score, axis=-1)


def _point_rank(logits: Any, point: jax.Array) -> jax.Array:
    if isinstance(logits, PixelLogits):
        return _rank(logits.logits, logits.to_index(point))
    if isinstance(logits, XYLogits):  # the joint score of (x, y) is x-logit + y-logit
        joint = (jax.nn.log_softmax(logits.x)[:, :, None]
                 + jax.nn.log_softmax(logits.y)[:, None, :])
        index = point[:, 0] * logits.y.shape[-1] + point[:, 1]
        return _rank(joint.reshape(joint.shape[0], -1), index)
    raise TypeError(f"point logits must be PixelLogits or XYLogits, got {type(logits).__name__}")


def _masked_mean(x: jax.Array, mask: jax.Array) -> jax.Array:
    mask = mask.astype(jnp.float32)
    return jnp.sum(x * mask) / jnp.maximum(jnp.sum(mask), 1.0)


def supervised_ranks(output: NetworkOutput, target: DenseAction, available_actions: jax.Array
                     ) -> dict[str, jax.Array]:
    """Each example's ranks of its target (0 = the network's first choice).

    Returns:
      {"function": int32 [B] (among the available functions), "screen", "minimap":
      int32 [B] (the target point among the argument's points), "uses_screen",
      "uses_minimap": bool [B] (the target function takes that argument)}.
    """
    masked = policy.mask_function_logits(output.function_logits, available_actions)
    used = policy.used_arguments(target.function)
    ranks = {"function": _rank(masked, target.function.astype(jnp.int32))}
    for name, i in (("screen", SCREEN), ("minimap", MINIMAP)):
        ranks[name] = _point_rank(output.argument_logits[i],
                                  target.arguments[i].astype(jnp.int32))
        ranks[f"uses_{name}"] = used[:, i].astype(bool)
    return ranks


def supervised_metrics(output: NetworkOutput, target: DenseAction, available_actions: jax.Array,
                       outcome: jax.Array) -> dict[str, jax.Array]:
    """Table 2's top-1/top-5 accuracies and the value accuracy.

    Returns:
      {"action_top1", "action_top5", "screen_top1", "screen_top5", "minimap_top1",
      "minimap_top5", "value_accuracy"}; screen and minimap accuracies are over the
      examples whose target function takes that argument (0 if none does).
    """
    ranks = supervised_ranks(output, target, available_actions)
    metrics = {"action_top1": jnp.mean(ranks["function"] < 1),
               "action_top5": jnp.mean(ranks["function"] < 5)}
    for name in ("screen", "minimap"):
        metrics[f"{name}_top1"] = _masked_mean(ranks[name] < 1, ranks[f"uses_{name}"])
        metrics[f"{name}_top5"] = _masked_mean(ranks[name] < 5, ranks[f"uses_{name}"])
    metrics["value_accuracy"] = jnp.mean((output.value > 0) == (outcome > 0.5))
    return metrics


def make_supervised_loss(network: nn.Module, *, value_weight: float = 1.0
                         ) -> Callable[[Any, SupervisedBatch], tuple[jax.Array, dict]]:
    """Builds `loss_fn(params, batch) -> (loss, metrics)` for a feed-forward network.

    Args:
      network: `AtariNet`, `FullyConv` or `ARFullyConv` (teacher-forced on the target).
      value_weight: weight of the value loss against the policy loss.
    """

    def loss_fn(params: Any, batch: SupervisedBatch) -> tuple[jax.Array, dict]:
        out = network.apply(params, batch.observation, batch.action)
        available = batch.observation["available_actions_mask"]
        res = supervised_loss(out, batch.action, available, batch.outcome,
                              value_weight=value_weight)
        metrics = {**res._asdict(), **supervised_metrics(out, batch.action, available,
                                                         batch.outcome)}
        return res.loss, metrics

    return loss_fn
