"""`threefry.split`, `threefry.bits` and `threefry.randint` are `jax.random`'s draws, jitted
and vmapped; `fusion.mask_once` is its mask, and `fusion.first_argmin` is `jnp.argmin`."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.engine.xla.fusion import first_argmin, mask_once

KEYS = [jax.random.PRNGKey(0), jax.random.PRNGKey(2 ** 31 - 1),
        jax.random.split(jax.random.PRNGKey(7))[1], jnp.array([0xFFFFFFFF, 0x12345678], jnp.uint32)]


@pytest.mark.parametrize("num", [1, 2, 3, 5])
@pytest.mark.parametrize("key", KEYS)
def test_split_is_jax_randoms(key, num):
    np.testing.assert_array_equal(threefry.split(key, num), jax.random.split(key, num))


@pytest.mark.parametrize("shape", [(1,), (23,), (28,), (4, 7), (0,)])
@pytest.mark.parametrize("key", KEYS)
def test_bits_are_jax_randoms(key, shape):
    np.testing.assert_array_equal(threefry.bits(key, shape),
                                  jax.random.bits(key, shape, jnp.uint32))


def test_jitted_and_vmapped_draws_are_jax_randoms():
    keys = jax.random.split(jax.random.PRNGKey(3), 16)
    ours = jax.jit(jax.vmap(lambda k: (threefry.split(k), threefry.bits(k, (28,)))))(keys)
    theirs = jax.vmap(lambda k: (jax.random.split(k), jax.random.bits(k, (28,), jnp.uint32)))(keys)
    for a, b in zip(ours, theirs):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("bounds", [(0, 573), (0, 1), (0, 0), (-1, 3), (5, 2), (0, 84),
                                    (0, 2 ** 31 - 1), (-2 ** 31, 2 ** 31 - 1)])
@pytest.mark.parametrize("key", KEYS)
def test_randint_is_jax_randoms(key, bounds):
    np.testing.assert_array_equal(threefry.randint(key, (9,), *bounds),
                                  jax.random.randint(key, (9,), *bounds))


def test_randint_with_a_bound_per_value_jitted_and_vmapped():
    keys = jax.random.split(jax.random.PRNGKey(5), 8)
    maxval = jnp.array([573, 64, 64, 2, 10, 1, 0, 500], jnp.int32)
    ours = jax.jit(jax.vmap(lambda k: threefry.randint(k, (8,), 0, maxval)))(keys)
    theirs = jax.vmap(lambda k: jax.random.randint(k, (8,), 0, maxval))(keys)
    np.testing.assert_array_equal(ours, theirs)


def test_too_many_draws_is_a_clear_error():
    with pytest.raises(ValueError, match="2\\*\\*32"):
        threefry.bits(KEYS[0], (2 ** 16, 2 ** 16))


def test_mask_once_is_the_mask():
    mask = jnp.array([[True, False, True], [False, False, True]])
    np.testing.assert_array_equal(jax.jit(mask_once)(mask), mask)
    assert mask_once(mask).dtype == jnp.bool_


@pytest.mark.parametrize("columns", [3, 8, 25])
def test_first_argmin_is_argmin(columns):
    # Ties (values on a coarse grid) take the first index; rows of inf only take 0.
    rng = np.random.default_rng(columns)
    x = np.floor(rng.uniform(0, 4, (6, 5, columns))).astype(np.float32)
    x[0, 0] = np.inf
    x[1, 2, ::2] = np.inf
    got = jax.jit(jax.vmap(first_argmin))(x)
    np.testing.assert_array_equal(got, np.argmin(x, axis=-1))
    assert got.dtype == jnp.int32
