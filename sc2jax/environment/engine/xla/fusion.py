"""Formulations for XLA's CPU backend: the fusion barriers `mask_once` and `materialize`,
`set_static` and `first_argmin`."""

from __future__ import annotations

import jax
import jax.numpy as jnp


def mask_once(mask):
    """bool mask, computed once however many elements of a broadcast read it.

    XLA fuses a cheap elementwise computation into every loop that reads it and
    recomputes it per element read: a unit's order-done test (a dozen comparisons) was
    evaluated for each of the 4 queued orders' fields and both axes of their points,
    eight times per unit for `order_pos` alone. An expensive producer (here a square
    root) is not fused into a consumer that reads its elements more than once, so
    `sqrt(float(mask)) > 0`, exactly `mask`, is written once; only the comparison is
    repeated. Measured in docs/benchmarks.md.

    Args:
      mask: bool array.
    """
    return jnp.sqrt(jnp.asarray(mask).astype(jnp.float32)) > 0


def materialize(x):
    """x, meant to be computed once: a fusion barrier for XLA's CPU backend.

    Left to itself, XLA fuses a small array's computation into each loop that reads it,
    and recomputes it per element read: the renderer's planes (the top unit's packed
    words, the terrain) for each of the 27 screen layers cut out of them, or a view's
    row and column cells for each pixel. `optimization_barrier` alone does not stop
    this on CPU (the backend expands barriers before fusing). An in-place update of x
    did when this was written (3bc49cc): XLA wrote x to a buffer before updating it.
    The update writes x's own first row back at an index hidden behind a barrier (a
    constant index would let XLA see through it), so it is an identity that costs one
    row.

    Not a hard barrier with this XLA (JAX 0.10.2): in the benchmark's compiled rollout
    the update is fused into the renderer's layer cut as well (its
    dynamic-update-slice sits inside the cut's fusion, at 1 and at 1,024 environments),
    so the terrain plane is again computed per layer. Measured side by side
    (FindAndDefeatZerglings, docs/benchmarks.md): this function made an identity, no
    difference (1.004x at one environment, 1.055x at 1,024, both within the noise); a
    `cond` with a hidden predicate, which XLA does not fuse through, 0.90x. An update of
    two rows, which XLA keeps a scatter and does not fuse, again computes the planes once
    (FindAndDefeatZerglings' screen cut: a fused computation of 33 instructions, not 193), and
    measured no faster either (1.018x at one environment, 0.986x at 64, 0.998x at 1,024):
    at 1,024 environments the cut takes what a plain fill of the layers takes.

    Args:
      x: an array of rank >= 1.
    """
    x = jnp.asarray(x)
    row = jax.lax.optimization_barrier(jnp.zeros(1, jnp.int32))
    return x.at[row].set(x[:1])


def set_static(x, values: dict):
    """x with x[i] = values[i] for each static index i of its first axis, written as
    slices joined by one concatenate, not a scatter.

    XLA's CPU backend compiles a while loop whose body has a scatter as a loop of
    separate kernels (`devices.compile_small_loops_whole`); `x.at[i].set(v)` with a
    constant i is a scatter, which XLA does not always turn back into a slice update.

    Args:
      x: an array [N, ...].
      values: index in [0, N) -> a value broadcastable to x.shape[1:] (cast to x's
        dtype).
    """
    x = jnp.asarray(x)
    row = lambda v: jnp.broadcast_to(jnp.asarray(v, x.dtype), x.shape[1:])[None]  # noqa: E731
    rows = [row(values[i]) if i in values else x[i:i + 1] for i in range(x.shape[0])]
    return jnp.concatenate(rows)


def first_argmin(x):
    """int32[...]: the index of the first minimum of x (without NaN) along its last axis,
    as `jnp.argmin`.

    For rows of 8 or more, the minimum and then the first index that reaches it: XLA's
    CPU backend runs argmin's (value, index) reduction far slower (the marines' nearest
    zergling, rows of 25: 4.1x at one environment, 1.6x at 64, docs/benchmarks.md). On
    shorter rows argmin is faster, and is used.
    """
    n = x.shape[-1]
    if n < 8:
        return jnp.argmin(x, axis=-1).astype(jnp.int32)
    low = jnp.min(x, axis=-1, keepdims=True)
    return jnp.min(jnp.where(x == low, jnp.arange(n, dtype=jnp.int32), n), axis=-1)
