"""The paper's random policy: uniform over the available functions, then uniform arguments."""

import jax
import numpy as np

from sc2jax.environment.agents import random_action
from sc2jax.environment.agents.random_agent import kth_true
from sc2jax.environment.interface.arguments import resolve_types

SAMPLES = 4000


def _sample(available, types):
    keys = jax.random.split(jax.random.PRNGKey(3), SAMPLES)
    act = jax.jit(jax.vmap(random_action, in_axes=(0, None, None)), static_argnums=2)
    return jax.device_get(act(keys, available, types))


def test_functions_are_uniform_over_the_available_ones():
    available = np.zeros(573, bool)
    available[[0, 2, 7, 331]] = True
    actions = _sample(available, resolve_types(24, 16))
    counts = np.bincount(actions.function, minlength=573)
    assert counts.sum() == counts[[0, 2, 7, 331]].sum()  # Never an unavailable one.
    # Each of 4 functions: 1000 expected, std 27; 150 is more than 5 std.
    np.testing.assert_allclose(counts[[0, 2, 7, 331]], SAMPLES / 4, atol=150)


def test_arguments_are_uniform_in_range_and_independent():
    types = resolve_types((24, 20), 16)
    actions = _sample(np.ones(573, bool), types)
    for t in types:
        values = np.asarray(getattr(actions, t.name)).reshape(SAMPLES, -1)
        assert values.shape[1] == len(t.sizes), t.name
        for column, size in zip(values.T, t.sizes):
            counts = np.bincount(column, minlength=size)
            assert len(counts) == size, (t.name, size)  # Nothing at or above the size.
            # Pearson's chi-square against uniform: mean size - 1, std sqrt(2 (size - 1)).
            expected = SAMPLES / size
            chi2 = ((counts - expected) ** 2 / expected).sum()
            assert chi2 < size - 1 + 6 * np.sqrt(2 * (size - 1)), (t.name, size, chi2)
    screen = np.asarray(actions.screen)
    # x and y are drawn independently (not one value used twice).
    assert np.corrcoef(screen[:, 0], screen[:, 1])[0, 1] < 0.1
    assert not np.array_equal(np.asarray(actions.screen), np.asarray(actions.screen2))


def test_typed_and_raw_keys_draw_the_same_action():
    # A raw key takes the fused `threefry.randint`, a typed one `jax.random.randint`.
    available = np.zeros(573, bool)
    available[[0, 1, 2, 3, 7, 12, 331]] = True
    types = resolve_types(24, 16)
    for seed in range(5):
        raw = jax.device_get(random_action(jax.random.PRNGKey(seed), available, types))
        typed = jax.device_get(random_action(jax.random.key(seed), available, types))
        for a, b in zip(raw, typed):
            np.testing.assert_array_equal(a, b)


def test_kth_true_finds_each_true_entry_in_order():
    rng = np.random.default_rng(0)
    masks = [rng.uniform(size=573) < p for p in (0.003, 0.05, 0.5, 0.97)]
    masks += [np.ones(573, bool), np.eye(573, dtype=bool)[0], np.eye(573, dtype=bool)[572]]
    find = jax.jit(jax.vmap(kth_true, in_axes=(None, 0)))
    for mask in masks:
        want = np.flatnonzero(mask)
        np.testing.assert_array_equal(find(mask, np.arange(len(want))), want)
