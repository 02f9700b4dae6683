"""The paper's random policy: a uniformly random available function, then uniformly
random arguments (SC2LE §4.4 "Random agents")."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.interface.arguments import Arguments
from sc2jax.environment.interface.dense import DenseAction


def kth_true(mask, k, width: int = 32):
    """int32: the index of the (k+1)-th True entry of bool[F] `mask` (0 <= k < its count).

    In two levels: the row of `width` entries that holds it, by the rows' running counts,
    then the entry within that row, each running count a sum over a triangle
    ([F / width, F / width] and [width, width]). A running count of all F entries is
    slower on XLA's CPU backend: `cumsum` is a window sum per entry, a log-depth scan
    some 30 small kernels (this: 1.04x the whole benchmark step at one environment,
    1.02x at 64; docs/benchmarks.md).
    """
    f = mask.shape[0]
    rows = -(-f // width)
    grid = jnp.pad(mask, (0, rows * width - f)).reshape(rows, width).astype(jnp.int32)

    def first_past(counts, k):  # The first entry whose running count exceeds k.
        n = counts.shape[0]
        upto = jnp.sum(jnp.where(np.tri(n, dtype=bool), counts[None, :], 0), axis=1)
        at = jnp.argmax(upto > k)
        return at, k - (upto[at] - counts[at])

    counts = jnp.sum(grid, axis=1)
    row, k = first_past(counts, k)
    column, _ = first_past(grid[row], k)
    return (row * width + column).astype(jnp.int32)


def random_action(key, available_actions, types: Arguments) -> DenseAction:
    """Samples one action.

    The function and every argument component come from one `randint` draw: the function
    as the k-th available one for a k uniform below their count (one number, where a
    categorical over all 573 functions would draw 573), a point argument as two
    components (x, y), the others as one.

    Args:
      key: RNG key (a raw `uint32[2]` key, or a typed one).
      available_actions: bool[num_functions], the observation's mask (no_op, at least,
        is always available).
      types: the argument types resolved to the environment's resolutions.

    Returns:
      An unbatched `DenseAction` (vmap for a batch).
    """
    available = jnp.asarray(available_actions, bool)
    count = jnp.sum(available, dtype=jnp.int32)
    sizes = [size for t in types for size in t.sizes]
    bounds = jnp.concatenate([count[None], jnp.array(sizes, jnp.int32)])
    if jnp.issubdtype(jnp.asarray(key).dtype, jax.dtypes.prng_key):  # A typed key.
        values = jax.random.randint(key, (len(bounds),), 0, bounds)
    else:  # The same draw, fused (`threefry`: JAX's hash is a loop of small kernels on CPU).
        values = threefry.randint(key, (len(bounds),), 0, bounds)
    function = kth_true(available, values[0])
    parts = jnp.split(values[1:], np.cumsum([len(t.sizes) for t in types])[:-1])
    arguments = [part if t.is_point else part[0] for part, t in zip(parts, types)]
    return DenseAction(function, *arguments)
