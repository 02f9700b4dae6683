"""A dense, batched action layout for networks and vectorised environments.

A `DenseAction` holds a function-id array and one int32 array per argument type, all
with the same leading batch shape: `[...]` for scalar arguments and `[..., 2]` (x, y)
for points. Arguments the function does not take are ignored (and zero after
`to_dense`). `to_dense` and `from_dense` convert from and to `FunctionCall`s without
loss.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from sc2jax.environment.interface.arguments import TYPES, Arguments
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, validate_function_call


class DenseAction(NamedTuple):
    """The dense action. Every field is an int32 array; `B...` is the batch shape.

    Attributes:
      function: [B...] function ids.
      screen, minimap, screen2: [B..., 2] points as (x, y).
      queued, control_group_act, control_group_id, select_point_act, select_add,
      select_unit_act, select_unit_id, select_worker, build_queue_id, unload_id: [B...].
    """

    function: Any
    screen: Any
    minimap: Any
    screen2: Any
    queued: Any
    control_group_act: Any
    control_group_id: Any
    select_point_act: Any
    select_add: Any
    select_unit_act: Any
    select_unit_id: Any
    select_worker: Any
    build_queue_id: Any
    unload_id: Any

    @property
    def arguments(self) -> tuple[Any, ...]:
        """The 13 argument arrays, in `TYPES` order."""
        return tuple(self[1:])

    @property
    def batch_shape(self) -> tuple[int, ...]:
        return tuple(np.shape(self.function))


assert DenseAction._fields[1:] == Arguments._fields


def zeros(batch_shape: Sequence[int] = ()) -> DenseAction:
    """Returns an all-zero (no_op) numpy `DenseAction` of the given batch shape."""
    batch_shape = tuple(batch_shape)
    return DenseAction(
        np.zeros(batch_shape, np.int32),
        *(np.zeros(batch_shape + ((2,) if t.is_point else ()), np.int32) for t in TYPES))


def to_dense(calls: FunctionCall | Sequence[FunctionCall],
             types: Arguments | None = None) -> DenseAction:
    """Converts one call (batch shape `()`) or a list of calls (batch shape `[n]`).

    Args:
      calls: a `FunctionCall` or a sequence of them.
      types: resolved argument types to validate against (point bounds); if None,
        only the function, argument counts and scalar ranges are checked.

    Raises:
      ValueError: if a call is invalid.
    """
    single = isinstance(calls, FunctionCall)
    batch = [calls] if single else list(calls)
    types = TYPES if types is None else types
    out = zeros((len(batch),))
    for i, call in enumerate(batch):
        call = validate_function_call(call, types)
        out.function[i] = call.function
        for arg_type, value in zip(FUNCTIONS[call.function].args, call.arguments):
            out[1 + arg_type.id][i] = value if arg_type.is_point else value[0]
    if single:
        return DenseAction(*(a[0] for a in out))
    return out


def from_dense(action: DenseAction) -> FunctionCall | list[FunctionCall]:
    """Converts a dense action back: batch shape `()` gives one `FunctionCall`, `[n]` a list.

    Raises:
      ValueError: for a batch of more than one dimension or an unknown function id.
    """
    arrays = DenseAction(*(np.asarray(a) for a in action))
    batch_shape = arrays.function.shape
    if len(batch_shape) > 1:
        raise ValueError(f"from_dense takes batch shape () or [n], got {batch_shape}")
    flat = [arrays] if not batch_shape else [
        DenseAction(*(a[i] for a in arrays)) for i in range(batch_shape[0])]
    calls = []
    for one in flat:
        function_id = int(one.function)
        if function_id not in FUNCTIONS:
            raise ValueError(f"unknown function id {function_id}; ids are 0..{len(FUNCTIONS) - 1}")
        args = [[int(v) for v in one[1 + t.id]] if t.is_point else [int(one[1 + t.id])]
                for t in FUNCTIONS[function_id].args]
        calls.append(FunctionCall(function_id, args))
    return calls[0] if not batch_shape else calls


def check_dense_action(action: Any, batch_shape: Sequence[int]) -> None:
    """Checks a dense action's structure, shapes and dtypes, before any compilation.

    Raises:
      TypeError: if `action` is not a `DenseAction`.
      ValueError: naming the field whose shape or dtype is wrong, and what is allowed.
    """
    if not isinstance(action, DenseAction):
        raise TypeError(f"expected a DenseAction, got {type(action).__name__}")
    batch_shape = tuple(batch_shape)
    for name, value in zip(DenseAction._fields, action):
        expected = batch_shape + ((2,) if name != "function" and TYPES[
            DenseAction._fields.index(name) - 1].is_point else ())
        shape, dtype = np.shape(value), getattr(value, "dtype", None)
        if dtype is None:
            dtype = np.asarray(value).dtype
        if tuple(shape) != expected:
            raise ValueError(f"action.{name} has shape {tuple(shape)}; expected {expected}")
        if not np.issubdtype(np.dtype(dtype), np.integer):
            raise ValueError(f"action.{name} has dtype {dtype}; expected an integer dtype (int32)")
