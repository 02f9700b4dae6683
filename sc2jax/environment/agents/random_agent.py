"""The paper's random policy: a uniformly random available function, then uniformly
random arguments (SC2LE §4.4 "Random agents")."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment import threefry
from sc2jax.environment.arguments import Arguments
from sc2jax.environment.dense import DenseAction


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
    # Available functions up to each one: a log-depth scan, where XLA's CPU backend runs
    # `cumsum` as a window sum per entry (573 x 573 additions; 2.7x slower, measured).
    rank = jax.lax.associative_scan(jnp.add, available.astype(jnp.int32))
    sizes = [size for t in types for size in t.sizes]
    bounds = jnp.concatenate([rank[-1:], jnp.array(sizes, jnp.int32)])
    if jnp.issubdtype(jnp.asarray(key).dtype, jax.dtypes.prng_key):  # A typed key.
        values = jax.random.randint(key, (len(bounds),), 0, bounds)
    else:  # The same draw, fused (`threefry`: JAX's hash is a loop of small kernels on CPU).
        values = threefry.randint(key, (len(bounds),), 0, bounds)
    function = jnp.argmax(rank > values[0]).astype(jnp.int32)
    parts = jnp.split(values[1:], np.cumsum([len(t.sizes) for t in types])[:-1])
    arguments = [part if t.is_point else part[0] for part, t in zip(parts, types)]
    return DenseAction(function, *arguments)
