"""The composite policy distribution over dense actions (paper §4.2).

An action is a function id a⁰ and the arguments a¹..a^L that a⁰ takes
(`FUNCTION_ARGS_MASK`). With independent heads (or, for arFullyConv, heads already
conditioned on a⁰ and a^{<l}),

    log π(a|s) = log π(a⁰|s) + Σ_{l used by a⁰} log π(a^l | a^{<l}, s).

Unavailable function ids are masked out and the distribution over a⁰ renormalised
(their logits are set to `MASKED_LOGIT`, so their probability is exactly 0 in float32
and they are never sampled). Arguments the function does not use contribute nothing:
no log-probability, no gradient, and they are set to 0 in sampled actions.

Point logits may be `PixelLogits` (one softmax over pixels) or `XYLogits`
(independent x and y: log π(x, y) = log π(x) + log π(y), H = H(x) + H(y)).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.functions import FUNCTION_ARGS_MASK
from sc2jax.networks.outputs import NetworkOutput, PixelLogits, XYLogits

MASKED_LOGIT = -1e9
"""The logit given to unavailable function ids (exp underflows to exactly 0)."""


class PolicyLogProb(NamedTuple):
    """Log-probabilities of a composite action.

    Attributes:
      total: [B...] log π(a|s), the function plus the used arguments.
      function: [B...] log π(a⁰|s) under the availability mask.
      arguments: 13-tuple (`TYPES` order) of [B...] log π(a^l|...), 0 where unused.
    """

    total: jax.Array
    function: jax.Array
    arguments: tuple[jax.Array, ...]


class PolicyEntropy(NamedTuple):
    """Entropies of each part of the policy (nats).

    Attributes:
      function: [B...] entropy of the masked function-id distribution.
      arguments: 13-tuple (`TYPES` order) of [B...] argument entropies (for every
        argument, used or not; weight them with `used_arguments`).
    """

    function: jax.Array
    arguments: tuple[jax.Array, ...]


def mask_function_logits(function_logits: jax.Array, available_actions: jax.Array) -> jax.Array:
    """Sets the logits of unavailable function ids to `MASKED_LOGIT`.

    Args:
      function_logits: [B..., F].
      available_actions: [B..., F] bool (or 0/1) mask.

    Returns:
      [B..., F] masked logits; softmax of them renormalises over available ids.
    """
    if jnp.shape(available_actions) != jnp.shape(function_logits):
        raise ValueError(f"available_actions has shape {jnp.shape(available_actions)}; expected "
                         f"the function logits' shape {jnp.shape(function_logits)}")
    return jnp.where(jnp.asarray(available_actions).astype(bool), function_logits, MASKED_LOGIT)


def used_arguments(function_id: jax.Array) -> jax.Array:
    """[B...] function ids -> [B..., 13] bool: which argument types each one takes."""
    return jnp.asarray(FUNCTION_ARGS_MASK)[function_id]


def categorical_log_prob(logits: jax.Array, value: jax.Array) -> jax.Array:
    log_p = jax.nn.log_softmax(logits, axis=-1)
    return jnp.take_along_axis(log_p, value.astype(jnp.int32)[..., None], axis=-1)[..., 0]


def categorical_entropy(logits: jax.Array) -> jax.Array:
    log_p = jax.nn.log_softmax(logits, axis=-1)
    return -jnp.sum(jnp.exp(log_p) * log_p, axis=-1)


def argument_log_prob(logits: Any, value: jax.Array) -> jax.Array:
    """log π of one argument value.

    Args:
      logits: [B..., n], `PixelLogits` or `XYLogits`.
      value: [B...] for a scalar argument, [B..., 2] (x, y) for a point.

    Returns:
      [B...] log-probabilities.
    """
    if isinstance(logits, PixelLogits):
        return categorical_log_prob(logits.logits, logits.to_index(value))
    if isinstance(logits, XYLogits):
        return (categorical_log_prob(logits.x, value[..., 0])
                + categorical_log_prob(logits.y, value[..., 1]))
    return categorical_log_prob(logits, value)


def argument_entropy(logits: Any) -> jax.Array:
    """Entropy [B...] of one argument's distribution (see `argument_log_prob`)."""
    if isinstance(logits, PixelLogits):
        return categorical_entropy(logits.logits)
    if isinstance(logits, XYLogits):
        return categorical_entropy(logits.x) + categorical_entropy(logits.y)
    return categorical_entropy(logits)


def noise_sizes(logits: Any) -> tuple[int, ...]:
    """The categorical sizes inside one head's logits: (H*W,), (X, Y) or (n,)."""
    if isinstance(logits, PixelLogits):
        return (logits.logits.shape[-1],)
    if isinstance(logits, XYLogits):
        return (logits.x.shape[-1], logits.y.shape[-1])
    return (jnp.shape(logits)[-1],)


def gumbel_noise(key: jax.Array, batch_shape: tuple[int, ...],
                 sizes: tuple[tuple[int, ...], ...]) -> list[list[jax.Array]]:
    """Gumbel(0, 1) noise for several categorical heads, drawn in one RNG call.

    One draw (instead of one per head) keeps the compiled program small: XLA compiles
    each random-number call separately, which is slow on CPU.

    Args:
      key: a PRNG key.
      batch_shape: [B...].
      sizes: per head, the sizes from `noise_sizes`.

    Returns:
      Per head, a list of [B..., n] noise arrays.
    """
    flat = [n for head in sizes for n in head]
    g = jax.random.gumbel(key, tuple(batch_shape) + (sum(flat),))
    pieces = jnp.split(g, np.cumsum(flat)[:-1].tolist(), axis=-1)
    out, i = [], 0
    for head in sizes:
        out.append(pieces[i:i + len(head)])
        i += len(head)
    return out


def choose(noise: jax.Array | None, logits: jax.Array,
           temperature: float | jax.Array = 1.0) -> jax.Array:
    """Samples from [B..., n] logits at a temperature by the Gumbel-max trick,
    argmax(logits / temperature + noise); the argmax if `noise` is None."""
    if noise is None:
        return jnp.argmax(logits, axis=-1).astype(jnp.int32)
    return jnp.argmax(logits / temperature + noise, axis=-1).astype(jnp.int32)


def argument_sample(noise: list[jax.Array] | None, logits: Any,
                    temperature: float | jax.Array = 1.0) -> jax.Array:
    """Samples one argument (the mode if `noise` is None).

    Args:
      noise: Gumbel noise from `gumbel_noise` for this head, or None.
      logits: [B..., n], `PixelLogits` or `XYLogits`.
      temperature: softmax temperature.

    Returns:
      [B...] int32 for a scalar argument, [B..., 2] (x, y) int32 for a point.
    """
    noise = [None, None] if noise is None else noise
    if isinstance(logits, PixelLogits):
        return logits.to_xy(choose(noise[0], logits.logits, temperature))
    if isinstance(logits, XYLogits):
        return jnp.stack([choose(noise[0], logits.x, temperature),
                          choose(noise[1], logits.y, temperature)], axis=-1)
    return choose(noise[0], logits, temperature)


def zero_unused(value: jax.Array, used: jax.Array) -> jax.Array:
    """Zeroes an argument value ([B...] or [B..., 2]) where `used` [B...] is False."""
    return jnp.where(used[..., None] if value.ndim > used.ndim else used, value, 0)


def sample(key: jax.Array | None, output: NetworkOutput, available_actions: jax.Array,
           temperature: float | jax.Array = 1.0) -> DenseAction:
    """Samples a composite action from independent heads (all networks but arFullyConv;
    its `sample` method conditions each argument on the previous choices).

    Args:
      key: a PRNG key, or None for the greedy (mode) action.
      output: the network output (batch shape [B...]).
      available_actions: [B..., F] bool mask; unavailable ids are never chosen.
      temperature: softmax temperature (> 0); low values are near-greedy.

    Returns:
      A `DenseAction` of int32 arrays; arguments the function does not use are 0.
    """
    if isinstance(temperature, (int, float)) and temperature <= 0:
        raise ValueError(f"temperature must be > 0, got {temperature}; use mode() for greedy")
    logits = mask_function_logits(output.function_logits, available_actions)
    heads = (logits,) + tuple(output.argument_logits)
    noise = [None] * len(heads) if key is None else gumbel_noise(
        key, logits.shape[:-1], tuple(noise_sizes(h) for h in heads))
    function = choose(None if key is None else noise[0][0], logits, temperature)
    used = used_arguments(function)
    args = [zero_unused(argument_sample(n, lg, temperature), used[..., i])
            for i, (n, lg) in enumerate(zip(noise[1:], output.argument_logits))]
    return DenseAction(function, *args)


def mode(output: NetworkOutput, available_actions: jax.Array) -> DenseAction:
    """The greedy action: the most likely available function and argument values."""
    return sample(None, output, available_actions)


def log_prob(output: NetworkOutput, action: DenseAction,
             available_actions: jax.Array) -> PolicyLogProb:
    """log π(a|s) = log π(a⁰|s) + Σ_{l used by a⁰} log π(a^l|·).

    Args:
      output: the network output, batch shape [B...] (for arFullyConv, computed with
        the same `action` for teacher forcing).
      action: a `DenseAction` with batch shape [B...].
      available_actions: [B..., F] bool mask.

    Returns:
      `PolicyLogProb`; unused arguments give exactly 0 and no gradient.
    """
    if not isinstance(action, DenseAction):
        raise TypeError(f"action must be a DenseAction, got {type(action).__name__}")
    logits = mask_function_logits(output.function_logits, available_actions)
    function = categorical_log_prob(logits, action.function)
    used = used_arguments(action.function)
    args = tuple(jnp.where(used[..., i], argument_log_prob(lg, value), 0.0)
                 for i, (lg, value) in enumerate(zip(output.argument_logits, action.arguments)))
    return PolicyLogProb(function + sum(args), function, args)


def entropy(output: NetworkOutput, available_actions: jax.Array) -> PolicyEntropy:
    """Entropies of the masked function distribution and of every argument head."""
    logits = mask_function_logits(output.function_logits, available_actions)
    return PolicyEntropy(categorical_entropy(logits),
                         tuple(argument_entropy(lg) for lg in output.argument_logits))
