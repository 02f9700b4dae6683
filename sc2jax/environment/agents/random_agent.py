"""The paper's random policy: a uniformly random available function, then uniformly
random arguments (SC2LE §4.4 "Random agents")."""

from __future__ import annotations

import jax
import jax.numpy as jnp

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
    keys = jax.random.split(key, len(types) + 1)
    logits = jnp.where(available_actions, 0.0, -jnp.inf)
    function = jax.random.categorical(keys[0], logits).astype(jnp.int32)
    arguments = []
    for k, t in zip(keys[1:], types):
        if t.is_point:
            arguments.append(jax.random.randint(k, (2,), 0, jnp.array(t.sizes)).astype(jnp.int32))
        else:
            arguments.append(jax.random.randint(k, (), 0, t.sizes[0]).astype(jnp.int32))
    return DenseAction(function, *arguments)
