"""`lazy_where` equals a plain `where`, unbatched, under vmap and under nested vmaps."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.lazy import FEW_LANES_DIVISOR, lazy_where


def _compute(operand):
    key, scale = operand
    return {"x": jax.random.uniform(key, (3,)) * scale, "n": jnp.int32(7)}


def _eager(pred, operand, otherwise):
    fresh = _compute(operand)
    return jax.tree_util.tree_map(lambda a, b: jnp.where(pred, a, b), fresh, otherwise)


def _otherwise(batch=()):
    return {"x": jnp.full(batch + (3,), -1.0), "n": jnp.full(batch, 2, jnp.int32)}


def _assert_same(a, b):
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def _assert_vmapped_same(preds, key):
    """Checks a vmapped, jitted `lazy_where` against `where` for a batch of predicates
    bool[B] (operands: B keys split from `key`, scales 0..B-1); returns its jaxpr."""
    batch = preds.shape[0]
    args = (preds, jax.random.split(key, batch), jnp.arange(batch, dtype=jnp.float32),
            _otherwise((batch,)))
    lazy = jax.jit(jax.vmap(lambda p, k, s, o: lazy_where(p, _compute, (k, s), o)))
    eager = jax.vmap(lambda p, k, s, o: _eager(p, (k, s), o))
    _assert_same(lazy(*args), eager(*args))
    return jax.make_jaxpr(lazy)(*args)


@pytest.mark.parametrize("pred", [True, False])
def test_unbatched_equals_where(pred):
    operand = (jax.random.PRNGKey(0), jnp.float32(2.0))
    pred = jnp.asarray(pred)
    _assert_same(jax.jit(lazy_where, static_argnums=1)(pred, _compute, operand, _otherwise()),
                 _eager(pred, operand, _otherwise()))


@pytest.mark.parametrize("preds", [[False] * 4, [True, False, False, True], [True] * 4])
def test_vmapped_equals_where(preds):
    _assert_vmapped_same(jnp.asarray(preds), jax.random.PRNGKey(1))


def test_unbatched_operand_and_otherwise_under_vmap():
    """Only the predicate is batched: the rest is broadcast over the batch."""
    preds = jnp.asarray([True, False, True])
    operand = (jax.random.PRNGKey(2), jnp.float32(3.0))
    lazy = jax.vmap(lambda p: lazy_where(p, _compute, operand, _otherwise()))(preds)
    eager = jax.vmap(lambda p: _eager(p, operand, _otherwise()))(preds)
    _assert_same(lazy, eager)


def test_nested_vmap_equals_where():
    preds = jnp.asarray([[True, False], [False, False], [False, True]])
    keys = jax.random.split(jax.random.PRNGKey(3), 6).reshape(3, 2, 2)
    scales = jnp.ones((3, 2))
    inner = lambda f: jax.vmap(jax.vmap(f))  # noqa: E731
    lazy = inner(lambda p, k, s, o: lazy_where(p, _compute, (k, s), o))
    eager = inner(lambda p, k, s, o: _eager(p, (k, s), o))
    _assert_same(lazy(preds, keys, scales, _otherwise((3, 2))),
                 eager(preds, keys, scales, _otherwise((3, 2))))


@pytest.mark.parametrize("taken", [[], [63], [0, 40], [5, 6, 7], list(range(0, 64, 2))])
def test_large_batches_equal_where_whether_few_or_many_take_the_branch(taken):
    """At 64 environments up to 64 // FEW_LANES_DIVISOR = 2 that take the branch are
    computed alone (gathered, then scattered back); more take the whole-batch path."""
    assert 64 // FEW_LANES_DIVISOR == 2
    preds = jnp.zeros(64, bool).at[jnp.asarray(taken, jnp.int32)].set(True)
    jaxpr = _assert_vmapped_same(preds, jax.random.PRNGKey(4))
    branches = [len(e.params["branches"]) for e in jaxpr.eqns[0].params["jaxpr"].eqns
                if e.primitive.name == "cond"]
    assert branches == [3]  # none, few, every
