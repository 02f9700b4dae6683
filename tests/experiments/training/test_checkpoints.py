"""Checkpoints: a trainer-like state and its metadata round-trip, old steps are pruned,
errors name what exists, and an interrupted save is never restored."""

import json
import os
from typing import Any, NamedTuple

import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest
from flax import struct

from sc2jax.atomic import write_json_atomic
from sc2jax.experiments.training.checkpoints import (
    Checkpointer,
    placed_as_restored,
)


class Counters(NamedTuple):
    step: jax.Array
    key: jax.Array


class TrainState(struct.PyTreeNode):
    params: Any
    opt_state: Any
    counters: Counters


def _state(seed: int) -> TrainState:
    """A small Dense layer, RMSProp after one update, an int32 step and a PRNGKey."""
    key = jax.random.PRNGKey(seed)
    params = nn.Dense(4).init(key, jnp.ones((1, 3)))
    optimiser = optax.rmsprop(1e-3)
    opt_state = optimiser.init(params)
    grads = jax.tree.map(jnp.ones_like, params)
    _, opt_state = optimiser.update(grads, opt_state, params)
    return TrainState(params, opt_state, Counters(jnp.int32(seed), jax.random.fold_in(key, 1)))


def _assert_same(actual, expected):
    assert jax.tree.structure(actual) == jax.tree.structure(expected)
    for a, e in zip(jax.tree.leaves(actual), jax.tree.leaves(expected)):
        assert isinstance(a, jax.Array)
        assert a.dtype == e.dtype and a.shape == e.shape
        np.testing.assert_array_equal(np.asarray(a), np.asarray(e))


def test_roundtrip_of_state_and_metadata(tmp_path):
    state = _state(7)
    meta = {"config": {"lr": 7e-4, "map": "MoveToBeacon"}, "env_steps": 123456, "wall": 1.5}
    with Checkpointer(tmp_path) as ckpt:
        assert ckpt.latest_step() is None and ckpt.all_steps() == []
        ckpt.save(10, state, meta)
    # A new Checkpointer, as after a restart; the target is abstract.
    with Checkpointer(tmp_path) as ckpt:
        assert ckpt.latest_step() == 10
        restored, restored_meta = ckpt.restore(jax.eval_shape(lambda: _state(0)))
    _assert_same(restored, state)
    assert restored.counters.key.dtype == jnp.uint32
    assert restored_meta == meta


def test_restore_into_concrete_target_and_default_metadata(tmp_path):
    state = _state(3)
    with Checkpointer(tmp_path) as ckpt:
        ckpt.save(0, state)
        restored, meta = ckpt.restore(_state(0))
    _assert_same(restored, state)
    assert meta == {}


def test_a_placed_fresh_state_and_a_restored_one_share_a_compiled_function(tmp_path):
    # A resumed run must not compile its training step again (placed as it started).
    fresh = placed_as_restored(_state(0))
    with Checkpointer(tmp_path) as checkpointer:
        checkpointer.save(1, fresh, {})
        restored, _ = checkpointer.restore(_state(0))
    step = jax.jit(lambda state: jax.tree.map(lambda x: x + 1, state.params))
    step(fresh)
    step(restored)
    assert step._cache_size() == 1
    step(_state(0))  # Unplaced: compiled again, which is what placing avoids.
    assert step._cache_size() == 2


def test_keeps_the_latest_max_to_keep_and_restores_older_steps(tmp_path):
    with Checkpointer(tmp_path, max_to_keep=2) as ckpt:
        for step in (1, 2, 5, 9):
            ckpt.save(step, _state(step), {"step": step})
        assert ckpt.latest_step() == 9
        assert ckpt.all_steps() == [5, 9]
        assert sorted(os.listdir(tmp_path)) == ["5", "9"]
        older, meta = ckpt.restore(_state(0), step=5)
    _assert_same(older, _state(5))
    assert meta == {"step": 5}


def test_errors_name_the_step_and_what_exists(tmp_path):
    with Checkpointer(tmp_path) as ckpt:
        with pytest.raises(FileNotFoundError, match="no checkpoint in"):
            ckpt.restore(_state(0))
        ckpt.save(4, _state(4))
        with pytest.raises(ValueError, match=r"step 3 .* available steps: \[4\]"):
            ckpt.restore(_state(0), step=3)
        with pytest.raises(ValueError, match=r"step 4 must be above the latest saved step 4"):
            ckpt.save(4, _state(4))
        with pytest.raises(ValueError, match="non-negative int, got -1"):
            ckpt.save(-1, _state(0))
        with pytest.raises(TypeError, match="JSON-serialisable"):
            ckpt.save(5, _state(5), {"array": np.zeros(2)})
        with pytest.raises(TypeError, match=r"leaf \['lr'\] is a float"):
            ckpt.restore({"lr": 1e-3})
        assert ckpt.all_steps() == [4]
    with pytest.raises(ValueError, match="max_to_keep must be a positive int, got 0"):
        Checkpointer(tmp_path, max_to_keep=0)


@pytest.mark.parametrize("suffix", [".orbax-checkpoint-tmp", ".orbax-checkpoint-tmp-1717171717"])
def test_interrupted_save_is_ignored_then_removed(tmp_path, suffix):
    with Checkpointer(tmp_path) as ckpt:
        ckpt.save(5, _state(5), {"step": 5})
    # What a save of step 7 killed before its rename leaves (Orbax names the temporary
    # directory `<step>.orbax-checkpoint-tmp`; older versions add `-<timestamp>`).
    partial = tmp_path / f"7{suffix}"
    (partial / "state").mkdir(parents=True)
    (partial / "state" / "manifest.ocdbt").write_bytes(b"\0" * 8)
    with Checkpointer(tmp_path) as ckpt:
        assert ckpt.latest_step() == 5 and ckpt.all_steps() == [5]
        restored, meta = ckpt.restore(_state(0))
        _assert_same(restored, _state(5))
        assert meta == {"step": 5}
        ckpt.save(7, _state(7))
        assert ckpt.all_steps() == [5, 7]
    assert not partial.exists()


def test_write_json_atomic_replaces_and_leaves_no_temporary_files(tmp_path):
    path = tmp_path / "results" / "eval.json"
    write_json_atomic(path, {"score": 1})
    write_json_atomic(path, {"score": [2, 3]})
    assert json.loads(path.read_text()) == {"score": [2, 3]}
    with pytest.raises(TypeError):
        write_json_atomic(path, {"score": object()})
    assert json.loads(path.read_text()) == {"score": [2, 3]}
    assert os.listdir(path.parent) == ["eval.json"]


def test_typed_prng_keys_roundtrip(tmp_path):
    state = {"key": jax.random.key(5), "w": jnp.arange(3.0)}
    with Checkpointer(tmp_path) as ckpt:
        ckpt.save(1, state)
        restored, _ = ckpt.restore(jax.eval_shape(lambda: state))
    np.testing.assert_array_equal(jax.random.key_data(restored["key"]),
                                  jax.random.key_data(state["key"]))
    np.testing.assert_array_equal(restored["w"], state["w"])
