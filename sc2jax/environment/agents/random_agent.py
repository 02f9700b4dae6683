"""The paper's random policy: a uniformly random available function, then uniformly
random arguments (SC2LE §4.4 "Random agents")."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.arguments import Arguments
from sc2jax.environment.dense import DenseAction


def random_action(key, available_actions, types: Arguments) -> DenseAction:
    """Samples one action.

    Args:
      key: RNG key.
      available_actions: bool[num_functions], the observation's mask.
      types: the argument types resolved to the environment's resolutions.

    Returns:
      An unbatched `DenseAction` (vmap for a batch).
    """
    function_key, argument_key = jax.random.split(key)
    logits = jnp.where(available_actions, 0.0, -jnp.inf)
    function = jax.random.categorical(function_key, logits).astype(jnp.int32)
    # Every argument component in one draw: a point argument is two (x, y), the others one.
    sizes = [size for t in types for size in t.sizes]
    values = jax.random.randint(argument_key, (len(sizes),), 0, jnp.array(sizes, jnp.int32))
    parts = jnp.split(values, np.cumsum([len(t.sizes) for t in types])[:-1])
    arguments = [part if t.is_point else part[0] for part, t in zip(parts, types)]
    return DenseAction(function, *arguments)
