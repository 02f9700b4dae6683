"""The composite policy distribution over raw actions (`RawAction`, PySC2's raw interface).

A raw action is a function id a⁰ of `RAW_FUNCTIONS` and the arguments it takes
(`RAW_ARGS_MASK`, in `RawAction` order): `world` a point of the raw grid, `queued`,
`units` (PySC2's `unit_tags`) a subset of the player's `raw_units` rows, and
`target_unit` (`target_unit_tag`) one row of any unit. With independent heads,

    log π(a|s) = log π(a⁰|s) + Σ_{l used by a⁰} log π(a^l|s),

where the commanded rows are independent Bernoulli choices, log π(units) = Σ_r log p_r
or log(1 - p_r) over the rows the player may command (`RawNetworkOutput.own`), and the
target is one softmax over the rows of real units (`RawNetworkOutput.real`). Unavailable
functions are masked as in `policy`; arguments the function does not take contribute
nothing and are set to 0 (the target to -1) in sampled actions.
"""

from __future__ import annotations

import sys
from types import ModuleType
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.interface.arguments import RAW_TYPES
from sc2jax.environment.interface.functions import RAW_FUNCTIONS
from sc2jax.environment.interface.raw import RawAction
from sc2jax.networks import policy
from sc2jax.networks.outputs import PixelLogits


class RawNetworkOutput(NamedTuple):
    """The output of a raw network.

    Attributes:
      value: [B...] the state value.
      function_logits: [B..., 564] unmasked logits of the raw function id.
      world: `PixelLogits` [B..., X*Y] over the raw grid.
      queued: [B..., 2] logits.
      units: [B..., N] the logit of commanding each `raw_units` row.
      target: [B..., N] the logit of targeting each row.
      own: bool [B..., N] the rows of the player's units (the only ones it commands).
      real: bool [B..., N] the rows of real units (the only targets).
    """

    value: jax.Array
    function_logits: jax.Array
    world: PixelLogits
    queued: jax.Array
    units: jax.Array
    target: jax.Array
    own: jax.Array
    real: jax.Array


def _args_mask() -> np.ndarray:
    mask = np.zeros((len(RAW_FUNCTIONS), 4), bool)
    field = {RAW_TYPES.world.id: 0, RAW_TYPES.queued.id: 1, RAW_TYPES.unit_tags.id: 2,
             RAW_TYPES.target_unit_tag.id: 3}
    for f in RAW_FUNCTIONS:
        mask[f.id, [field[a.id] for a in f.args]] = True
    return mask


RAW_ARGS_MASK = _args_mask()
"""bool[564, 4]: the arguments (world, queued, units, target_unit) each raw function takes."""


def used_arguments(function_id: jax.Array) -> jax.Array:
    """[B...] raw function ids -> [B..., 4] bool: which arguments each one takes."""
    return jnp.asarray(RAW_ARGS_MASK)[function_id]


def _target_logits(output: RawNetworkOutput) -> jax.Array:
    return jnp.where(output.real, output.target, policy.MASKED_LOGIT)


def _units_log_prob(output: RawNetworkOutput, units: jax.Array) -> jax.Array:
    """Σ over own rows of log p (commanded) or log(1 - p) (not), [B...]."""
    chosen = jnp.where(units, jax.nn.log_sigmoid(output.units),
                       jax.nn.log_sigmoid(-output.units))
    return jnp.sum(jnp.where(output.own, chosen, 0.0), axis=-1)


def _units_entropy(output: RawNetworkOutput) -> jax.Array:
    """Σ over own rows of the Bernoulli entropies, [B...]."""
    p = jax.nn.sigmoid(output.units)
    h = -(p * jax.nn.log_sigmoid(output.units) + (1 - p) * jax.nn.log_sigmoid(-output.units))
    return jnp.sum(jnp.where(output.own, h, 0.0), axis=-1)


def sample(key: jax.Array | None, output: RawNetworkOutput, available_actions: jax.Array,
           temperature: float | jax.Array = 1.0) -> RawAction:
    """Samples a raw action (the mode if `key` is None: the likeliest function, world
    point, queued and target, and every row whose probability is above one half).

    Args:
      key: a PRNG key or None.
      output: the network output, batch shape [B...].
      available_actions: [B..., 564] bool mask; unavailable ids are never chosen.
      temperature: softmax temperature (> 0), also dividing the row logits.

    Returns:
      A `RawAction` of int32 arrays (`units` bool); arguments the function does not take
      are 0 (no rows, target -1).
    """
    if isinstance(temperature, (int, float)) and temperature <= 0:
        raise ValueError(f"temperature must be > 0, got {temperature}; use key=None for greedy")
    logits = policy.mask_function_logits(output.function_logits, available_actions)
    heads = (logits, output.world, output.queued, _target_logits(output))
    batch = logits.shape[:-1]
    if key is None:
        noise, unit_noise = [None] * len(heads), jnp.zeros(output.units.shape)
    else:
        key, unit_key = jax.random.split(key)
        noise = policy.gumbel_noise(key, batch, tuple(policy.noise_sizes(h) for h in heads))
        unit_noise = jax.random.logistic(unit_key, output.units.shape)
    function = policy.choose(None if key is None else noise[0][0], logits, temperature)
    used = used_arguments(function)
    world = policy.zero_unused(policy.argument_sample(noise[1], output.world, temperature),
                               used[..., 0])
    queued = policy.zero_unused(policy.argument_sample(noise[2], output.queued, temperature),
                                used[..., 1])
    # Bernoulli(σ(l / T)) by the logistic trick: l / T + Logistic(0, 1) > 0.
    units = (output.units / temperature + unit_noise > 0) & output.own & used[..., 2:3]
    target = jnp.where(used[..., 3], policy.argument_sample(noise[3], heads[3], temperature),
                       -1)
    return RawAction(function, world, queued, units, target)


def log_prob(output: RawNetworkOutput, action: RawAction,
             available_actions: jax.Array) -> policy.PolicyLogProb:
    """log π(a|s) of raw actions.

    Args:
      output: the network output, batch shape [B...].
      action: a `RawAction` with batch shape [B...].
      available_actions: [B..., 564] bool mask.

    Returns:
      `policy.PolicyLogProb` with 4 arguments (`RawAction` order); unused ones are 0.
    """
    if not isinstance(action, RawAction):
        raise TypeError(f"action must be a RawAction, got {type(action).__name__}")
    logits = policy.mask_function_logits(output.function_logits, available_actions)
    function = policy.categorical_log_prob(logits, action.function)
    used = used_arguments(action.function)
    parts = (policy.argument_log_prob(output.world, action.world),
             policy.argument_log_prob(output.queued, action.queued),
             _units_log_prob(output, action.units),
             policy.argument_log_prob(_target_logits(output), jnp.maximum(action.target_unit, 0)))
    args = tuple(jnp.where(used[..., i], part, 0.0) for i, part in enumerate(parts))
    return policy.PolicyLogProb(function + sum(args), function, args)


def entropy(output: RawNetworkOutput, available_actions: jax.Array) -> policy.PolicyEntropy:
    """Entropies of the masked function distribution and of the 4 argument heads."""
    logits = policy.mask_function_logits(output.function_logits, available_actions)
    return policy.PolicyEntropy(
        policy.categorical_entropy(logits),
        (policy.argument_entropy(output.world), policy.argument_entropy(output.queued),
         _units_entropy(output), policy.argument_entropy(_target_logits(output))))


def policy_of(output: Any) -> ModuleType:
    """The policy functions (`sample`, `log_prob`, `entropy`, `used_arguments`) of a
    network's output: this module's for a `RawNetworkOutput`, else `policy`'s."""
    return sys.modules[__name__] if isinstance(output, RawNetworkOutput) else policy
