"""PySC2's raw action interface (`action_space="raw"`): a dense, batched layout of raw
function calls (`RAW_FUNCTIONS`), and its conversion from `FunctionCall`s.

A raw call commands units and targets one by unit tag; as PySC2 does, a "tag" smaller
than the number of rows of the last `raw_units` observation stands for that row's unit
(PySC2 v4's `find_original_tag`), any other for the unit of that tag. The dense layout
names units by row alone (a mask over `raw_units` rows), so that a policy can point at
them; `to_raw_dense` turns tags into rows. `world` is a point of the raw grid
(`camera.RawGrid`, `raw_units`' own coordinates), x in `[0, resolution_x)`, y in
`[0, resolution_y)`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from dm_env import specs

from sc2jax.environment.interface.functions import RAW_FUNCTIONS, FunctionCall, validate_raw_call
from sc2jax.environment.interface.observation_tables import FeatureUnit

NUM_RAW_FUNCTIONS = len(RAW_FUNCTIONS)


class RawAction(NamedTuple):
    """The dense raw action; every field an array with the batch shape `B...` first.

    Attributes:
      function: int32 [B...] `RAW_FUNCTIONS` ids.
      world: int32 [B..., 2] (x, y) on the raw grid.
      queued: int32 [B...] 0 (now) or 1 (queued).
      units: bool [B..., max_units] the `raw_units` rows commanded (`unit_tags`).
      target_unit: int32 [B...] the `raw_units` row targeted (`target_unit_tag`), or -1.
    """

    function: Any
    world: Any
    queued: Any
    units: Any
    target_unit: Any

    @property
    def batch_shape(self) -> tuple[int, ...]:
        return tuple(np.shape(self.function))


def raw_zeros(max_units: int, batch_shape: Sequence[int] = ()) -> RawAction:
    """A numpy raw `no_op` of the given batch shape."""
    batch_shape = tuple(batch_shape)
    return RawAction(np.zeros(batch_shape, np.int32), np.zeros(batch_shape + (2,), np.int32),
                     np.zeros(batch_shape, np.int32),
                     np.zeros(batch_shape + (max_units,), bool),
                     np.full(batch_shape, -1, np.int32))


def raw_action_spec(max_units: int, resolution: tuple[int, int]) -> RawAction:
    """The dense raw action spec: a `RawAction` of `BoundedArray`s (no batch dim)."""
    rx, ry = resolution
    return RawAction(
        specs.BoundedArray((), np.int32, 0, NUM_RAW_FUNCTIONS - 1, name="function"),
        specs.BoundedArray((2,), np.int32, (0, 0), (rx - 1, ry - 1), name="world"),
        specs.BoundedArray((), np.int32, 0, 1, name="queued"),
        specs.BoundedArray((max_units,), np.bool_, False, True, name="units"),
        specs.BoundedArray((), np.int32, -1, max_units - 1, name="target_unit"))


def _row_of(tag: int, tags: np.ndarray, argument: str) -> int:
    """The `raw_units` row a raw call's tag names (a row index, else a unit's tag)."""
    if tag < len(tags):
        return tag
    rows = np.flatnonzero(tags == tag)
    if not len(rows):
        raise ValueError(f"{argument} {tag} is neither a row of the last raw_units "
                         f"(0..{len(tags) - 1}) nor the tag of a unit in them")
    return int(rows[0])


def to_raw_dense(call: FunctionCall, raw_units: np.ndarray, resolution: tuple[int, int]
                 ) -> RawAction:
    """Converts one raw call (batch shape `()`), naming units by tag or row.

    Args:
      call: a `FunctionCall` of `RAW_FUNCTIONS`.
      raw_units: [n, 46] the rows of the last `raw_units` observation (PySC2's layout:
        its real rows only), or the padded [max_units, 46] (rows of type 0 are padding).
      resolution: the raw grid's (x, y) resolution.

    Raises:
      ValueError: for a bad call, a point off the grid, or a tag that is neither a row
        nor the tag of a unit in `raw_units`.
    """
    call = validate_raw_call(call)
    raw_units = np.asarray(raw_units)
    real = raw_units[:, FeatureUnit.unit_type] != 0
    tags = raw_units[real, FeatureUnit.tag]
    out = raw_zeros(len(raw_units))
    out.function[...] = call.function
    func = RAW_FUNCTIONS[call.function]
    for arg_type, value in zip(func.args, call.arguments):
        if arg_type.name == "world":
            if not all(0 <= v < r for v, r in zip(value, resolution)):
                raise ValueError(f"{func.name} argument 'world' = {tuple(value)} is off the "
                                 f"raw grid: x in 0..{resolution[0] - 1}, y in "
                                 f"0..{resolution[1] - 1}")
            out.world[:] = value
        elif arg_type.name == "queued":
            out.queued[...] = value[0]
        elif arg_type.name == "unit_tags":
            out.units[[_row_of(t, tags, "unit tag") for t in value]] = True
        else:
            out.target_unit[...] = _row_of(value[0], tags, "target unit tag")
    return out


def check_raw_action(action: Any, batch_shape: Sequence[int], max_units: int,
                     resolution: tuple[int, int]) -> RawAction:
    """Checks a dense raw action's shapes and ranges, before any compilation; returns it
    as numpy arrays (int32, and bool `units`).

    Raises:
      TypeError: if `action` is not a `RawAction`.
      ValueError: naming the field whose shape or values are wrong, and what is allowed.
    """
    if not isinstance(action, RawAction):
        raise TypeError(f"expected a RawAction, got {type(action).__name__}")
    batch_shape = tuple(batch_shape)
    rx, ry = resolution
    allowed = {"function": ((), 0, NUM_RAW_FUNCTIONS - 1), "world": ((2,), 0, None),
               "queued": ((), 0, 1), "units": ((max_units,), 0, 1),
               "target_unit": ((), -1, max_units - 1)}
    out = []
    for name, value in zip(RawAction._fields, action):
        value = np.asarray(value)
        tail, low, high = allowed[name]
        if value.shape != batch_shape + tail:
            raise ValueError(f"action.{name} has shape {value.shape}; expected "
                             f"{batch_shape + tail}")
        if name == "units":
            if value.dtype != np.bool_:
                raise ValueError(f"action.units has dtype {value.dtype}; expected bool")
            out.append(value)
            continue
        if not np.issubdtype(value.dtype, np.integer):
            raise ValueError(f"action.{name} has dtype {value.dtype}; expected an integer "
                             "dtype (int32)")
        if name == "world":
            bad = (value < 0) | (value >= np.asarray([rx, ry]))
            what = f"x in 0..{rx - 1}, y in 0..{ry - 1}"
        else:
            bad = (value < low) | (value > high)
            what = f"{low}..{high}"
        if np.any(bad):
            raise ValueError(f"action.{name} has values outside {what}: "
                             f"{np.unique(value[bad]).tolist()[:8]}")
        out.append(value.astype(np.int32))
    return RawAction(*out)
