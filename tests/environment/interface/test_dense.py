"""Tests for the dense action layout."""

import numpy as np
import pytest

from sc2jax.environment import (
    FUNCTIONS,
    DenseAction,
    FunctionCall,
    check_dense_action,
    from_dense,
    resolve_types,
    to_dense,
)
from sc2jax.environment.interface import dense as dense_lib

CALLS = [
    FUNCTIONS.no_op(),
    FUNCTIONS.move_camera((10, 20)),
    FUNCTIONS.select_point("toggle", (3, 4)),
    FUNCTIONS.select_rect("add", (1, 2), (30, 40)),
    FUNCTIONS.select_control_group("set_and_steal", 7),
    FUNCTIONS.select_unit("deselect", 42),
    FUNCTIONS.select_idle_worker("add_all"),
    FUNCTIONS.select_army("add"),
    FUNCTIONS.select_larva(),
    FUNCTIONS.unload(499),
    FUNCTIONS.build_queue(9),
    FUNCTIONS.Move_screen("queued", (63, 0)),
    FUNCTIONS.Attack_minimap("now", (5, 6)),
    FUNCTIONS.Stop_quick("queued"),
    FUNCTIONS.Effect_Restore_autocast(),
]


def test_round_trip_every_call():
    dense = to_dense(CALLS)
    assert dense.function.shape == (len(CALLS),) and dense.screen.shape == (len(CALLS), 2)
    assert all(a.dtype == np.int32 for a in dense)
    assert from_dense(dense) == CALLS
    for call in CALLS:
        single = to_dense(call)
        assert single.batch_shape == ()
        assert from_dense(single) == call


def test_round_trip_every_function():
    # One call per function with its maximal argument values.
    types = resolve_types(64, 32)
    calls = []
    for f in FUNCTIONS:
        args = [[t.sizes[0] - 1, t.sizes[1] - 1] if t.is_point else [t.sizes[0] - 1]
                for t in (types[a.id] for a in f.args)]
        calls.append(FunctionCall(f.id, args))
    assert from_dense(to_dense(calls, types)) == calls


def test_unused_arguments_are_zero():
    dense = to_dense(FUNCTIONS.Move_screen("queued", (5, 6)))
    assert int(dense.queued) == 1 and list(dense.screen) == [5, 6]
    assert list(dense.minimap) == [0, 0] and int(dense.select_add) == 0


def test_to_dense_validates():
    with pytest.raises(ValueError, match="x in 0..15"):
        to_dense([FunctionCall(331, [[0], [16, 0]])], resolve_types(16, 16))


def test_from_dense_errors():
    bad = dense_lib.zeros((2,))._replace(function=np.array([0, 999], np.int32))
    with pytest.raises(ValueError, match="unknown function id 999"):
        from_dense(bad)
    with pytest.raises(ValueError, match=r"batch shape \(\) or \[n\]"):
        from_dense(dense_lib.zeros((2, 2)))


def test_check_dense_action():
    check_dense_action(dense_lib.zeros((4,)), (4,))
    with pytest.raises(ValueError, match=r"action.function has shape \(3,\); expected \(4,\)"):
        check_dense_action(dense_lib.zeros((3,)), (4,))
    bad = dense_lib.zeros((4,))._replace(screen=np.zeros((4, 2), np.float32))
    with pytest.raises(ValueError, match="action.screen has dtype float32"):
        check_dense_action(bad, (4,))
    bad = dense_lib.zeros((4,))._replace(screen=np.zeros((4,), np.int32))
    with pytest.raises(ValueError, match=r"action.screen has shape \(4,\); expected \(4, 2\)"):
        check_dense_action(bad, (4,))
    with pytest.raises(TypeError, match="expected a DenseAction"):
        check_dense_action(CALLS[0], ())


def test_dense_action_is_a_pytree():
    import jax

    leaves = jax.tree_util.tree_leaves(dense_lib.zeros((2,)))
    assert len(leaves) == len(DenseAction._fields) == 14
