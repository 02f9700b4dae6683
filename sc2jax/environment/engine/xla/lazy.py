"""Computing only what is used, under `vmap` too: `lazy_where` and `smallest_fit`.

`lazy_where` is a `where` that computes its first branch only when it is taken.

The engine has rare, costly events: an episode's auto-reset, a beacon that moves, a new
wave of shards or zerglings. Written as `jnp.where(event, costly(...), kept)`, the costly
value is computed on every step for every environment and then thrown away. `lazy_where`
computes it only when it is used:

- unbatched, through `lax.cond`;
- under `vmap`, where a `cond` on a batched predicate would compute both branches for
  every environment: not at all when no environment takes the branch, for just the
  environments that take it when they are few (at most 1/32 of the batch, for batches of
  32 or more), and for the whole batch otherwise. For batches of 32 or more these are
  two `while_loop`s, not a `switch`: a loop that runs no iteration costs nothing, where
  XLA copies every leaf of `otherwise` through a branch that returns it (about 110 copy
  kernels per agent step of FindAndDefeatZerglings at 64 environments).

Either way the result is the same as the plain `where`, bit for bit.

`smallest_fit` runs a computation compiled for several sizes at the smallest size that
fits (the game loops and observations of maps whose unit slots fill up, on the slots in
use); under `vmap`, at the smallest that fits the whole batch. Where the size needed is
a guess, the computation can say that it did not fit, and the next size runs.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import jax
import jax.numpy as jnp
import numpy as np

Out = TypeVar("Out")

# Under vmap, when at most 1/FEW_LANES_DIVISOR of the batch takes the branch, only those
# environments are computed (gathered into a batch of that size).
FEW_LANES_DIVISOR = 32


def lazy_where(pred, compute: Callable[[Any], Out], operand: Any, otherwise: Out,
               large_batches: str = "lazy") -> Out:
    """`compute(operand)` where `pred`, else `otherwise`, computing it only when used.

    Args:
      pred: bool scalar.
      compute: operand -> a pytree with the structure, shapes and dtypes of `otherwise`.
        It must take every traced value it needs through `operand` (it may close over
        constants only): under `vmap` it is run on the batch.
      operand: a pytree of arrays, `compute`'s input.
      otherwise: the value where `pred` is False.
      large_batches: under `vmap` of `FEW_LANES_DIVISOR` or more environments, "lazy"
        (the two loops of the module docstring) or "always": `compute` run for the whole
        batch and its result taken as it is, for a cheap `compute` that some environment
        of a large batch needs on most calls (the loops then cost more than they save)
        and that gives `otherwise` where `pred` is False.

    Returns:
      A pytree like `otherwise`.
    """

    if large_batches not in ("lazy", "always"):
        raise ValueError(f"large_batches must be 'lazy' or 'always', got {large_batches!r}")

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

        def every_lane():
            fresh = jax.vmap(compute)(operand)
            return jax.tree_util.tree_map(
                lambda a, b: jnp.where(pred.reshape((-1,) + (1,) * (a.ndim - 1)), a, b),
                fresh, otherwise)

        lanes = axis_size // FEW_LANES_DIVISOR
        if lanes >= 1 and large_batches == "always":
            out = jax.vmap(compute)(operand)
            return out, jax.tree_util.tree_map(lambda _: True, out)
        if lanes < 1:  # A `cond`: a loop over the lanes measured 0.35x at one environment.
            out = jax.lax.cond(jnp.any(pred), every_lane, lambda: otherwise)
            return out, jax.tree_util.tree_map(lambda _: True, out)

        def lanes_at_once(size: int, carry):
            """The first `size` pending environments computed (gathered; the rows past
            the pending ones padded with an out-of-range index, computed from
            environment 0 and dropped) and written into the result."""
            pending, out = carry
            (rows,) = jnp.nonzero(pending, size=size, fill_value=axis_size)
            safe = jnp.minimum(rows, axis_size - 1)
            fresh = jax.vmap(compute)(jax.tree_util.tree_map(lambda x: x[safe], operand))
            out = jax.tree_util.tree_map(lambda b, a: b.at[rows].set(a, mode="drop"), out,
                                         fresh)
            return pending.at[rows].set(False, mode="drop"), out

        # Loops, not a `switch` (module docstring). The first runs once, for the whole
        # batch, when more than `lanes` take the branch; the second `lanes` at a time.
        carry = jax.lax.while_loop(lambda c: jnp.sum(c[0]) > lanes,
                                   functools.partial(lanes_at_once, axis_size),
                                   (pred, otherwise))
        out = jax.lax.while_loop(lambda c: jnp.any(c[0]),
                                 functools.partial(lanes_at_once, lanes), carry)[1]
        return out, jax.tree_util.tree_map(lambda _: True, out)

    return select(pred, operand, otherwise)


def smallest_fit(need, sizes: Sequence[int], compute: Callable[[int, Any], Any],
                 operand: Any, *, checked: bool = False):
    """`compute(size, operand)` for the smallest of `sizes` that is at least `need` (the
    largest where none is): every size is compiled, one runs (or, `checked`, a few).

    Under `vmap` one size serves the whole batch, the smallest that fits every
    environment's `need`, and so under nested `vmap`s (each level takes its batch's
    largest). The caller guarantees that every size that fits gives the same result, so
    that an environment's result does not depend on the rest of its batch.

    With `checked`, `compute` also says whether its size was enough, for a `need` that
    is a good guess rather than a bound: `compute(size, operand)` returns `(out, fits)`,
    and where `fits` is False (for any environment of the batch) the next size runs, up
    to the largest, whose result is taken as it is. One call site runs every try (a
    `while_loop` around the `switch`), so each size is compiled once.

    Args:
      need: int32 scalar.
      sizes: ascending static ints.
      compute: (size, operand) -> a pytree of the same structure, shapes and dtypes for
        every size; with `checked`, a pair (that pytree, bool scalar). It must take every
        traced value it needs through `operand`.
      operand: a pytree of arrays.

    Returns:
      The pytree (without the `fits` of `checked`).
    """
    sizes = tuple(sizes)
    if not sizes or list(sizes) != sorted(set(sizes)):
        raise ValueError(f"sizes must be ascending and distinct, got {sizes!r}")
    bounds = np.asarray(sizes[:-1], np.int32)
    branches = [functools.partial(compute, s) for s in sizes]

    @jax.custom_batching.custom_vmap
    def run(need, operand):
        index = jnp.sum(jnp.asarray(bounds) < need).astype(jnp.int32)
        if not checked:
            return jax.lax.switch(index, branches, operand)
        last = len(sizes) - 1

        def attempt(carry):
            index, _, _ = carry
            out, fits = jax.lax.switch(index, branches, operand)
            return index + 1, out, fits | (index == last)

        shapes = jax.eval_shape(branches[-1], operand)[0]
        nothing = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)
        return jax.lax.while_loop(lambda carry: ~carry[2], attempt,
                                  (index, nothing, jnp.bool_(False)))[1]

    @run.def_vmap
    def run_batched(axis_size, in_batched, need, operand):
        operand = jax.tree_util.tree_map(
            lambda x, b: x if b else jnp.broadcast_to(x, (axis_size,) + x.shape), operand,
            in_batched[1])

        def batched(size, op):
            out = jax.vmap(functools.partial(compute, size))(op)
            return (out[0], jnp.all(out[1])) if checked else out

        out = smallest_fit(jnp.max(need), sizes, batched, operand, checked=checked)
        return out, jax.tree_util.tree_map(lambda _: True, out)

    return run(need, operand)
