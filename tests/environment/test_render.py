"""The renderer's fusion barrier is an identity, alone, jitted and under vmap."""

import jax
import numpy as np

from sc2jax.environment.render import materialize


def test_materialize_is_an_identity():
    x = np.arange(4 * 5 * 6, dtype=np.int32).reshape(4, 5, 6) * 7 - 3
    np.testing.assert_array_equal(materialize(x), x)
    np.testing.assert_array_equal(jax.jit(materialize)(x), x)
    batch = np.stack([x, -x, x + 1])
    np.testing.assert_array_equal(jax.jit(jax.vmap(materialize))(batch), batch)
    # Inside a larger program, where XLA may fuse around it.
    doubled = jax.jit(lambda a: materialize(a * 2)[np.array([2, 0, 3])] >> 1)(x)
    np.testing.assert_array_equal(doubled, x[[2, 0, 3]])
