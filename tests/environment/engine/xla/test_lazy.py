"""`lazy_where` equals a plain `where`, unbatched, under vmap and under nested vmaps;
`smallest_fit` runs the smallest size that fits, per batch."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.engine.xla.lazy import FEW_LANES_DIVISOR, lazy_where, smallest_fit
from tests.environment.helpers import assert_trees_equal


def _compute(operand):
    key, scale = operand
    return {"x": jax.random.uniform(key, (3,)) * scale, "n": jnp.int32(7)}


def _eager(pred, operand, otherwise):
    fresh = _compute(operand)
    return jax.tree_util.tree_map(lambda a, b: jnp.where(pred, a, b), fresh, otherwise)


def _otherwise(batch=()):
    return {"x": jnp.full(batch + (3,), -1.0), "n": jnp.full(batch, 2, jnp.int32)}


def _assert_vmapped_same(preds, key):
    """Checks a vmapped, jitted `lazy_where` against `where` for a batch of predicates
    bool[B] (operands: B keys split from `key`, scales 0..B-1); returns its jaxpr."""
    batch = preds.shape[0]
    args = (preds, jax.random.split(key, batch), jnp.arange(batch, dtype=jnp.float32),
            _otherwise((batch,)))
    lazy = jax.jit(jax.vmap(lambda p, k, s, o: lazy_where(p, _compute, (k, s), o)))
    eager = jax.vmap(lambda p, k, s, o: _eager(p, (k, s), o))
    assert_trees_equal(lazy(*args), eager(*args))
    return jax.make_jaxpr(lazy)(*args)


@pytest.mark.parametrize("pred", [True, False])
def test_unbatched_equals_where(pred):
    operand = (jax.random.PRNGKey(0), jnp.float32(2.0))
    pred = jnp.asarray(pred)
    assert_trees_equal(jax.jit(lazy_where, static_argnums=1)(pred, _compute, operand, _otherwise()),
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
    assert_trees_equal(lazy, eager)


def test_nested_vmap_equals_where():
    preds = jnp.asarray([[True, False], [False, False], [False, True]])
    keys = jax.random.split(jax.random.PRNGKey(3), 6).reshape(3, 2, 2)
    scales = jnp.ones((3, 2))
    inner = lambda f: jax.vmap(jax.vmap(f))  # noqa: E731
    lazy = inner(lambda p, k, s, o: lazy_where(p, _compute, (k, s), o))
    eager = inner(lambda p, k, s, o: _eager(p, (k, s), o))
    assert_trees_equal(lazy(preds, keys, scales, _otherwise((3, 2))),
                 eager(preds, keys, scales, _otherwise((3, 2))))


@pytest.mark.parametrize("taken", [[], [63], [0, 40], [5, 6, 7], list(range(0, 64, 2)),
                                   list(range(64))])
def test_large_batches_equal_where_whether_few_or_many_take_the_branch(taken):
    """At 64 environments up to 64 // FEW_LANES_DIVISOR = 2 that take the branch are
    computed alone (gathered, then scattered back); more, the whole batch at once. Both
    are loops that run no iteration when none takes it, and no `cond` (whose branch
    not taken would copy `otherwise`)."""
    assert 64 // FEW_LANES_DIVISOR == 2
    preds = jnp.zeros(64, bool).at[jnp.asarray(taken, jnp.int32)].set(True)
    jaxpr = _assert_vmapped_same(preds, jax.random.PRNGKey(4))
    names = [e.primitive.name for e in jaxpr.eqns[0].params["jaxpr"].eqns]
    assert names.count("while") == 2 and "cond" not in names


def _compute_or_keep(operand):
    """A `compute` that gives `otherwise` where its predicate is False (as
    `large_batches="always"` asks): the operand's values, kept where not taken."""
    take, fresh, kept = operand
    return jnp.where(take, fresh, kept)


@pytest.mark.parametrize("batch", [4, 64])
def test_always_computes_large_batches_and_is_lazy_below(batch):
    """`large_batches="always"`: at 64 environments `compute` runs for the whole batch
    (no loop, no `cond`); at 4 a `cond` runs it only when some environment needs it."""
    preds = jnp.arange(batch) % 3 == 0
    fresh, kept = jnp.arange(batch, dtype=jnp.float32), -jnp.ones(batch)
    fn = jax.vmap(lambda p, f, k: lazy_where(p, _compute_or_keep, (p, f, k), k,
                                             large_batches="always"))
    np.testing.assert_array_equal(jax.jit(fn)(preds, fresh, kept),
                                  jnp.where(preds, fresh, kept))
    jaxpr = str(jax.make_jaxpr(fn)(preds, fresh, kept))
    assert "while" not in jaxpr
    assert ("cond" in jaxpr) == (batch < FEW_LANES_DIVISOR)


def test_rejects_an_unknown_large_batches_policy():
    with pytest.raises(ValueError, match="large_batches.*'lazy' or 'always'.*'loops'"):
        lazy_where(jnp.bool_(True), _compute, (jax.random.PRNGKey(0), 1.0), _otherwise(),
                   large_batches="loops")


SIZES = (4, 8, 16)


def _sized(size, operand):
    """The size that ran, and the operand's first `size` entries summed (a result that
    is the same for every size holding the operand's non-zero entries)."""
    return {"size": jnp.int32(size), "sum": jnp.sum(operand[:size])}


def _fit(need, operand):
    return smallest_fit(need, SIZES, _sized, operand)


@pytest.mark.parametrize("need, size", [(0, 4), (4, 4), (5, 8), (16, 16), (99, 16)])
def test_smallest_fit_runs_the_smallest_size_that_fits(need, size):
    operand = jnp.arange(16.0) * (jnp.arange(16) < min(need, 16))
    out = jax.jit(_fit)(jnp.int32(need), operand)
    assert int(out["size"]) == size
    assert float(out["sum"]) == float(jnp.sum(operand))


def test_smallest_fit_takes_the_batch_largest_need_under_vmap_and_nested_vmaps():
    needs = jnp.asarray([[1, 3], [2, 6], [0, 0]])
    operands = jnp.where(jnp.arange(16) < needs[..., None], 1.0, 0.0)
    out = jax.jit(jax.vmap(_fit))(needs[0], operands[0])
    np.testing.assert_array_equal(out["size"], [4, 4])
    nested = jax.jit(jax.vmap(jax.vmap(_fit)))(needs, operands)
    np.testing.assert_array_equal(nested["size"], np.full((3, 2), 8))
    np.testing.assert_array_equal(nested["sum"], needs)
    # One switch of three sizes in the program, under both vmaps: one size runs.
    jaxpr = jax.make_jaxpr(jax.vmap(jax.vmap(_fit)))(needs, operands)
    assert "select_n" not in str(jaxpr)


@pytest.mark.parametrize("sizes", [(), (8, 4), (4, 4, 8)])
def test_smallest_fit_rejects_sizes_that_do_not_ascend(sizes):
    with pytest.raises(ValueError, match="ascending"):
        smallest_fit(jnp.int32(1), sizes, _sized, jnp.zeros(16))


def _checked(size, operand):
    """`_sized`, and whether every non-zero entry lies within the size."""
    return _sized(size, operand), jnp.all(operand[size:] == 0)


def _fit_checked(need, operand):
    return smallest_fit(need, SIZES, _checked, operand, checked=True)


@pytest.mark.parametrize("need, used, size", [(0, 0, 4), (1, 6, 8), (5, 6, 8), (1, 12, 16),
                                              (1, 16, 16), (9, 2, 16)])
def test_checked_smallest_fit_tries_larger_sizes_until_one_fits(need, used, size):
    """`need` is a guess: where a size does not fit, the next runs (the largest is
    taken as it is); a guess larger than needed is still the size that runs."""
    operand = jnp.where(jnp.arange(16) < used, 1.0, 0.0)
    out = jax.jit(_fit_checked)(jnp.int32(need), operand)
    assert int(out["size"]) == size
    assert float(out["sum"]) == used


def test_checked_smallest_fit_retries_the_whole_batch_and_compiles_each_size_once():
    needs = jnp.asarray([[1, 1], [2, 2]])
    used = jnp.asarray([[1, 2], [3, 9]])
    operands = jnp.where(jnp.arange(16) < used[..., None], 1.0, 0.0)
    out = jax.jit(jax.vmap(_fit_checked))(needs[0], operands[0])
    np.testing.assert_array_equal(out["size"], [4, 4])
    nested = jax.jit(jax.vmap(jax.vmap(_fit_checked)))(needs, operands)
    np.testing.assert_array_equal(nested["size"], np.full((2, 2), 16))
    np.testing.assert_array_equal(nested["sum"], used)
    jaxpr = str(jax.make_jaxpr(jax.vmap(jax.vmap(_fit_checked)))(needs, operands))
    assert jaxpr.count("while[") == 1 and jaxpr.count("cond[") == 1
