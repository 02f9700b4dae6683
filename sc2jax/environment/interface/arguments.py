"""The 13 action-argument types of PySC2 v4, and the 4 of its raw actions, declared once
as data.

An argument is either a point (`screen`, `minimap`, `screen2`: two sizes, x then y,
set by the resolution) or a single integer in `[0, size)`, some of them with named
enum values (`queued`: "now" or "queued", ...). Ids, names, order and sizes follow
PySC2's `actions.TYPES`. The raw actions' (`RAW_TYPES`, PySC2's `actions.RAW_TYPES`)
are a world point (`world`), `queued`, and unit tags: `unit_tags` (1 to 512 of them)
and `target_unit_tag` (one).
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from typing import NamedTuple

Size = int | Sequence[int]


class Queued(enum.IntEnum):
    now = 0
    queued = 1


class ControlGroupAct(enum.IntEnum):
    recall = 0
    set = 1
    append = 2
    set_and_steal = 3
    append_and_steal = 4


class SelectPointAct(enum.IntEnum):
    select = 0
    toggle = 1
    select_all_type = 2
    add_all_type = 3


class SelectAdd(enum.IntEnum):
    select = 0
    add = 1


class SelectUnitAct(enum.IntEnum):
    select = 0
    deselect = 1
    select_all_type = 2
    deselect_all_type = 3


class SelectWorker(enum.IntEnum):
    select = 0
    add = 1
    select_all = 2
    add_all = 3


class ArgumentType(NamedTuple):
    """One argument type.

    Attributes:
        id: PySC2's id, the index in `TYPES`.
        name: PySC2's name.
        sizes: `(x_size, y_size)` for a point, `(n,)` for a scalar in `[0, n)`. Points are
            `(0, 0)` in the unresolved `TYPES`; `resolve_types` fills in the resolution.
        values: the enum naming the scalar's values, or None.
    """

    id: int
    name: str
    sizes: tuple[int, ...]
    values: type[enum.IntEnum] | None = None

    @property
    def is_point(self) -> bool:
        return len(self.sizes) == 2

    def __str__(self) -> str:
        return f"{self.id}/{self.name} {list(self.sizes)}"


class Arguments(NamedTuple):
    """The 13 argument types, in PySC2's order (the field index is the id)."""

    screen: ArgumentType
    minimap: ArgumentType
    screen2: ArgumentType
    queued: ArgumentType
    control_group_act: ArgumentType
    control_group_id: ArgumentType
    select_point_act: ArgumentType
    select_add: ArgumentType
    select_unit_act: ArgumentType
    select_unit_id: ArgumentType
    select_worker: ArgumentType
    build_queue_id: ArgumentType
    unload_id: ArgumentType


def _make_types(screen: tuple[int, int], minimap: tuple[int, int]) -> Arguments:
    specs = {
            "screen": (screen, None),
            "minimap": (minimap, None),
            "screen2": (screen, None),
            "queued": ((2,), Queued),
            "control_group_act": ((5,), ControlGroupAct),
            "control_group_id": ((10,), None),
            "select_point_act": ((4,), SelectPointAct),
            "select_add": ((2,), SelectAdd),
            "select_unit_act": ((4,), SelectUnitAct),
            "select_unit_id": ((500,), None),
            "select_worker": ((4,), SelectWorker),
            "build_queue_id": ((10,), None),
            "unload_id": ((500,), None),
    }
    return Arguments(*(
            ArgumentType(i, name, tuple(sizes), values)
            for i, (name, (sizes, values)) in enumerate(specs.items())))


TYPES = _make_types((0, 0), (0, 0))
"""The argument types with unresolved point sizes, as PySC2's `actions.TYPES`."""

NUM_TYPES = len(TYPES)


class RawArguments(NamedTuple):
    """The raw actions' 4 argument types, in PySC2's order (the field index is the id)."""

    world: ArgumentType
    queued: ArgumentType
    unit_tags: ArgumentType
    target_unit_tag: ArgumentType


MAX_RAW_UNIT_TAGS = 512
"""The most unit tags a raw command takes (PySC2's `RAW_TYPES.unit_tags`)."""
RAW_TYPES = RawArguments(
    world=ArgumentType(0, "world", (0, 0)),
    queued=ArgumentType(1, "queued", (2,), Queued),
    unit_tags=ArgumentType(2, "unit_tags", (MAX_RAW_UNIT_TAGS,)),
    target_unit_tag=ArgumentType(3, "target_unit_tag", (1,)))
"""The raw argument types: `world` a point in the raw resolution (unresolved here);
`unit_tags` and `target_unit_tag` take unit tags, the size being how many."""
POINT_TYPES = tuple(t for t in TYPES if t.is_point)
SCALAR_TYPES = tuple(t for t in TYPES if not t.is_point)


def normalize_size(size: Size, name: str, low: int = 1, high: int = 4096) -> tuple[int, int]:
    """Returns a resolution as `(x, y)`, from an int (square) or an `(x, y)` pair.

    Raises:
        ValueError: if a side is not an integer in `[low, high]`.
    """
    error = ValueError(f"{name} must be an int or an (x, y) pair of ints, got {size!r}")
    if isinstance(size, bool):
        raise error
    if hasattr(size, "__index__"):
        pair = (size, size)
    elif isinstance(size, (tuple, list)) and len(size) == 2:
        pair = tuple(size)
    else:
        raise error
    out = []
    for side in pair:
        if isinstance(side, bool) or not hasattr(side, "__index__"):
            raise error
        side_int = int(side.__index__())
        if not low <= side_int <= high:
            raise ValueError(f"{name} must be in [{low}, {high}] pixels per side, got {size!r}")
        out.append(side_int)
    return (out[0], out[1])


def resolve_types(screen_size: Size, minimap_size: Size) -> Arguments:
    """Returns `TYPES` with the point sizes of this resolution.

    Args:
        screen_size: the feature-screen resolution, an int or `(x, y)`.
        minimap_size: the feature-minimap resolution, an int or `(x, y)`.
    """
    return _make_types(normalize_size(screen_size, "screen_size"),
                                          normalize_size(minimap_size, "minimap_size"))
