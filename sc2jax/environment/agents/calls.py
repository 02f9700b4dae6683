"""Building blocks of jittable policies: one `DenseAction` from named arguments, a choice
between two actions, and the `Policy` type that agents share."""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from sc2jax.environment.interface.dense import DenseAction

Policy = Callable[[jax.Array, dict], DenseAction]
"""(key, one environment's padded observation) -> an unbatched `DenseAction`."""


def call(function, **arguments) -> DenseAction:
    """An unbatched jnp `DenseAction`: `function` with the named arguments, others 0.

    Args:
      function: int32 scalar function id (may be traced).
      **arguments: argument-type name -> int32 value ([2] (x, y) for points).
    """
    fields = {}
    for name in DenseAction._fields[1:]:
        shape = (2,) if name in ("screen", "minimap", "screen2") else ()
        value = arguments.pop(name, jnp.zeros(shape, jnp.int32))
        fields[name] = jnp.broadcast_to(jnp.asarray(value, jnp.int32), shape)
    if arguments:
        raise ValueError(f"unknown argument types {sorted(arguments)}; allowed: "
                         f"{list(DenseAction._fields[1:])}")
    return DenseAction(function=jnp.asarray(function, jnp.int32), **fields)


def pick(condition, if_true: DenseAction, if_false: DenseAction) -> DenseAction:
    """`if_true` where `condition` (a bool scalar) holds, else `if_false`."""
    return jax.tree_util.tree_map(lambda a, b: jnp.where(condition, a, b), if_true, if_false)
