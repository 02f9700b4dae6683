"""`lazy_where`: a `where` that computes its first branch only when it is taken.

The engine has rare, costly events: an episode's auto-reset, a beacon that moves, a new
wave of shards or zerglings. Written as `jnp.where(event, costly(...), kept)`, the costly
value is computed on every step for every environment and then thrown away. `lazy_where`
computes it only when it is used:

- unbatched, through `lax.cond`;
- under `vmap`, where a `cond` on a batched predicate would compute both branches for
  every environment, for the whole batch when any environment of it takes the branch,
  and not at all otherwise.

Either way the result is the same as the plain `where`, bit for bit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import jax
import jax.numpy as jnp

Out = TypeVar("Out")


def lazy_where(pred, compute: Callable[[Any], Out], operand: Any, otherwise: Out) -> Out:
    """`compute(operand)` where `pred`, else `otherwise`, computing it only when used.

    Args:
      pred: bool scalar.
      compute: operand -> a pytree with the structure, shapes and dtypes of `otherwise`.
        It must take every traced value it needs through `operand` (it may close over
        constants only): under `vmap` it is run on the batch.
      operand: a pytree of arrays, `compute`'s input.
      otherwise: the value where `pred` is False.

    Returns:
      A pytree like `otherwise`.
    """

    @jax.custom_batching.custom_vmap
    def select(pred, operand, otherwise):
        return jax.lax.cond(pred, lambda: compute(operand), lambda: otherwise)

    @select.def_vmap
    def select_batched(axis_size, in_batched, pred, operand, otherwise):
        def batched(x, is_batched):
            return x if is_batched else jnp.broadcast_to(x, (axis_size,) + x.shape)

        pred_batched, operand_batched, otherwise_batched = in_batched
        pred = batched(pred, pred_batched)
        operand = jax.tree_util.tree_map(batched, operand, operand_batched)
        otherwise = jax.tree_util.tree_map(batched, otherwise, otherwise_batched)

        def computed():
            fresh = jax.vmap(compute)(operand)
            return jax.tree_util.tree_map(
                lambda a, b: jnp.where(pred.reshape((-1,) + (1,) * (a.ndim - 1)), a, b),
                fresh, otherwise)

        out = jax.lax.cond(jnp.any(pred), computed, lambda: otherwise)
        return out, jax.tree_util.tree_map(lambda _: True, out)

    return select(pred, operand, otherwise)
