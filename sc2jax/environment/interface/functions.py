"""PySC2 v4's 573 action functions, built from the table in `data/pysc2_functions.tsv`,
and its 564 raw functions (`RAW_FUNCTIONS`, from `data/pysc2_raw_functions.tsv`).

`FUNCTIONS[331]`, `FUNCTIONS.Move_screen` and `FUNCTIONS["Move_screen"]` are the same
`Function`. Calling a function builds a `FunctionCall` the way PySC2 users write it:
`FUNCTIONS.Move_screen("now", (12, 30))`, `RAW_FUNCTIONS.Attack_pt("now", [tag], (x, y))`.
"""

from __future__ import annotations

import enum
import importlib.resources
from collections.abc import Iterator, Sequence
from typing import Any, NamedTuple

import numpy as np

from sc2jax.environment.interface.arguments import (
    RAW_TYPES,
    TYPES,
    Arguments,
    ArgumentType,
)


class FunctionType(enum.IntEnum):
    """How a function is turned into an SC2 action (PySC2's `function_type`)."""

    no_op = 0
    move_camera = 1
    select_point = 2
    select_rect = 3
    select_unit = 4
    control_group = 5
    select_idle_worker = 6
    select_army = 7
    select_warp_gates = 8
    select_larva = 9
    unload = 10
    build_queue = 11
    cmd_quick = 12
    cmd_screen = 13
    cmd_minimap = 14
    autocast = 15
    raw_no_op = 16
    raw_move_camera = 17
    raw_cmd = 18
    raw_cmd_pt = 19
    raw_cmd_unit = 20
    raw_autocast = 21


UI_FUNCTION_TYPES = frozenset(FunctionType(i) for i in range(12))
"""Function types that act on the user interface rather than send an ability."""
RAW_FUNCTION_TYPES = frozenset(FunctionType(i) for i in range(16, 22))
"""The raw functions' types."""


class Function(NamedTuple):
    """One action function.

    Attributes:
      id: PySC2's function id.
      name: PySC2's name, e.g. "Move_screen".
      function_type: how it becomes an SC2 action.
      args: its argument types, in order.
      ability_id: the SC2 ability it sends (0 for UI functions).
      general_id: the general ability it maps to (0 if it is itself general).
    """

    id: int
    name: str
    function_type: FunctionType
    args: tuple[ArgumentType, ...]
    ability_id: int
    general_id: int

    def __call__(self, *args: Any) -> FunctionCall:
        """Builds a `FunctionCall`, with enum values given by name or number.

        Raises:
          ValueError: if the number of arguments or an enum value is wrong.
        """
        if self.function_type in RAW_FUNCTION_TYPES:
            return validate_raw_call(FunctionCall(self.id, list(args)))
        return FunctionCall.init_with_validation(self, args)

    def __str__(self) -> str:
        return f"{self.id}/{self.name} ({'; '.join(str(a) for a in self.args)})"


class Functions:
    """All functions, indexable by id (`FUNCTIONS[331]`) and by name
    (`FUNCTIONS.Move_screen`, `FUNCTIONS["Move_screen"]`)."""

    def __init__(self, functions: Sequence[Function]):
        self._list = tuple(functions)
        self._by_name = {f.name: f for f in self._list}
        if [f.id for f in self._list] != list(range(len(self._list))):
            raise ValueError("function ids must be 0..n-1 in order")
        if len(self._by_name) != len(self._list):
            raise ValueError("function names must be unique")

    def __getattr__(self, name: str) -> Function:
        try:
            return self.__dict__["_by_name"][name]
        except KeyError:
            raise AttributeError(f"no function named {name!r}") from None

    def __getitem__(self, key: int | str) -> Function:
        if isinstance(key, str):
            try:
                return self._by_name[key]
            except KeyError:
                raise KeyError(f"no function named {key!r}") from None
        index = _as_index(key)
        if index is None or not 0 <= index < len(self._list):
            raise KeyError(f"unknown function id {key!r}; ids are 0..{len(self._list) - 1}")
        return self._list[index]

    def __contains__(self, key: object) -> bool:
        if isinstance(key, str):
            return key in self._by_name
        index = _as_index(key)
        return index is not None and 0 <= index < len(self._list)

    def __iter__(self) -> Iterator[Function]:
        return iter(self._list)

    def __len__(self) -> int:
        return len(self._list)

    def __dir__(self):
        return list(super().__dir__()) + list(self._by_name)


def _as_index(key: object) -> int | None:
    if isinstance(key, bool):
        return None
    try:
        return int(key.__index__())  # type: ignore[attr-defined]
    except (AttributeError, TypeError):
        return None


def _load_functions(file: str = "pysc2_functions.tsv", types=TYPES) -> Functions:
    data = importlib.resources.files("sc2jax.environment.interface") / "data"
    text = (data / file).read_text(encoding="utf-8")
    lines = [line for line in text.splitlines() if line and not line.startswith("#")]
    header = lines[0].split("\t")
    rows = []
    for line in lines[1:]:
        row = dict(zip(header, line.split("\t")))
        args = tuple(getattr(types, a) for a in row["args"].split(",") if a)
        rows.append(Function(
            id=int(row["id"]),
            name=row["name"],
            function_type=FunctionType[row["function_type"]],
            args=args,
            ability_id=int(row["ability_id"]),
            general_id=int(row["general_id"]),
        ))
    return Functions(rows)


FUNCTIONS = _load_functions()
NUM_FUNCTIONS = len(FUNCTIONS)
RAW_FUNCTIONS = _load_functions("pysc2_raw_functions.tsv", RAW_TYPES)
"""PySC2 v4's raw functions (`actions.RAW_FUNCTIONS`): ids, names, types, arguments
(`RAW_TYPES`) and abilities as its table."""

FUNCTION_ARGS_MASK = np.zeros((NUM_FUNCTIONS, len(TYPES)), dtype=bool)
"""[num_functions, num_types]: True where a function takes an argument type."""
for _f in FUNCTIONS:
    FUNCTION_ARGS_MASK[_f.id, [a.id for a in _f.args]] = True
FUNCTION_ARGS_MASK.flags.writeable = False

FUNCTION_TYPE_IDS = np.array([f.function_type for f in FUNCTIONS], dtype=np.int32)
ABILITY_IDS = np.array([f.ability_id for f in FUNCTIONS], dtype=np.int32)
GENERAL_IDS = np.array([f.general_id for f in FUNCTIONS], dtype=np.int32)

_BY_ABILITY = {(f.ability_id, f.function_type): f.id for f in FUNCTIONS if f.ability_id}
_GENERAL = {f.ability_id: f.general_id for f in FUNCTIONS if f.ability_id and f.general_id}


def function_for_ability(ability_id: int, function_type: FunctionType) -> int | None:
    """The function id a client sees for an ability used as `function_type`, as PySC2's
    `reverse_action` finds it (with `hide_specific_actions`): the general ability's
    function of that type where the ability is a specific one, else its own; None where
    PySC2 has no such function."""
    return _BY_ABILITY.get((_GENERAL.get(ability_id, ability_id), function_type))


ALWAYS = ("no_op", "move_camera", "select_point", "select_rect", "select_control_group")
"""The functions PySC2 makes available on every step."""

# The specific ability the game reports (in a unit's abilities and orders) for each
# general ability of the simulator's Terran units: SCVs, Marines, Command Centers and
# Barracks. Other abilities are their own.
SPECIFIC_ABILITY = {FUNCTIONS[general].ability_id: FUNCTIONS[specific].ability_id
                    for general, specific in (
                        ("Attack_screen", "Attack_Attack_screen"),
                        ("Move_screen", "Move_Move_screen"),
                        ("Patrol_screen", "Patrol_Patrol_screen"),
                        ("HoldPosition_quick", "HoldPosition_Hold_quick"),
                        ("Stop_quick", "Stop_Stop_quick"),
                        ("Harvest_Gather_screen", "Harvest_Gather_SCV_screen"),
                        ("Harvest_Return_quick", "Harvest_Return_SCV_quick"),
                        ("Rally_Workers_screen", "Rally_CommandCenter_screen"),
                        ("Rally_Units_screen", "Rally_Building_screen"),
                        ("Cancel_quick", "Cancel_BuildInProgress_quick"),
                        ("Cancel_Last_quick", "Cancel_Queue5_quick"))}
for _a in (FUNCTION_TYPE_IDS, ABILITY_IDS, GENERAL_IDS):
    _a.flags.writeable = False


class FunctionCall(NamedTuple):
    """A function id and its arguments, as PySC2 writes them.

    `arguments` is a list with one list per argument: `[value]` for a scalar and
    `[x, y]` for a point, e.g. `FunctionCall(331, [[0], [12, 30]])`.
    """

    function: int
    arguments: list[list[int]]

    @classmethod
    def init_with_validation(cls, function: Function | int | str,
                             arguments: Sequence[Any]) -> FunctionCall:
        """Builds a call, converting enum names (`"now"`, `"select_all_type"`) to values.

        Checks the function exists, the argument count, each argument's arity, and
        that scalar arguments lie in `[0, size)`. Point bounds depend on the
        resolution; `validate_function_call` checks them.

        Raises:
          ValueError: naming the function, the argument, the value and what is allowed.
        """
        return validate_function_call(cls(function, list(arguments)), TYPES)

    @classmethod
    def all_arguments(cls, function: Function | int | str,
                      arguments: Arguments | dict[str, Any]) -> FunctionCall:
        """Builds a call from values for every argument type, keeping those it uses.

        Args:
          function: the function.
          arguments: an `Arguments` tuple (or a dict by type name) holding a value for
            at least each argument the function takes.
        """
        func = _lookup(function)
        values = arguments._asdict() if isinstance(arguments, Arguments) else dict(arguments)
        missing = [a.name for a in func.args if a.name not in values]
        if missing:
            raise ValueError(f"{func.name} needs arguments {missing}, got {sorted(values)}")
        return cls.init_with_validation(func, [values[a.name] for a in func.args])


def validate_function_call(call: FunctionCall, types: Arguments) -> FunctionCall:
    """Checks a call against resolved argument types and returns it normalised.

    Normalised means enum names replaced by their values and points floored to ints.

    Args:
      call: the call, e.g. `FunctionCall(331, [[0], [12, 30]])`.
      types: `arguments.resolve_types(screen_size, minimap_size)`.

    Raises:
      ValueError: for an unknown function id, a wrong number of arguments, or an
        argument outside its range (points outside the screen or minimap included),
        naming the function, the argument, the value and the allowed range.
    """
    if not isinstance(call, FunctionCall):
        if isinstance(call, (tuple, list)) and len(call) == 2:
            call = FunctionCall(*call)
        else:
            raise ValueError(f"expected a FunctionCall(function, arguments), got {call!r}")
    func = _lookup(call.function)
    arguments = call.arguments
    if not isinstance(arguments, (list, tuple)) or len(arguments) != len(func.args):
        n = len(arguments) if isinstance(arguments, (list, tuple)) else arguments
        raise ValueError(
            f"{func.name} takes {len(func.args)} arguments "
            f"({', '.join(a.name for a in func.args) or 'none'}), got {n}: {arguments!r}")
    return FunctionCall(func.id, [_convert_argument(func, types[t.id], v)
                                  for t, v in zip(func.args, arguments)])


def _raw_function_of_ability() -> np.ndarray:
    table = np.zeros(max(f.ability_id for f in RAW_FUNCTIONS) + 1, np.int32)
    for f in sorted(RAW_FUNCTIONS, key=lambda f: -f.id):  # The lowest id wins.
        if f.ability_id > 0:
            table[f.ability_id] = f.id
    table.flags.writeable = False
    return table


RAW_FUNCTION_OF_ABILITY = _raw_function_of_ability()
"""int32[max ability + 1]: the raw function an order of each ability is reported as in
unit rows (`order_id_*`), PySC2's `RAW_ABILITY_ID_TO_FUNC_ID` (the lowest raw function
id of the ability; 0 for abilities without one)."""


def validate_raw_call(call: FunctionCall) -> FunctionCall:
    """Checks a raw call (`RAW_FUNCTIONS`) and returns it normalised: `queued` by name
    or value, `unit_tags` a tag or a list of 1 to `MAX_RAW_UNIT_TAGS` tags,
    `target_unit_tag` one tag, `world` an (x, y) point of numbers >= 0 (floored).

    Raises:
      ValueError: for an unknown raw function, a wrong number of arguments, or a bad
        argument, naming the function, the argument, the value and what is allowed.
    """
    try:
        func = RAW_FUNCTIONS[call.function.id if isinstance(call.function, Function)
                             else call.function]
    except KeyError as e:
        raise ValueError(f"unknown raw function {call.function!r}; ids are "
                         f"0..{len(RAW_FUNCTIONS) - 1} or a name such as 'Attack_pt'") from e
    arguments = call.arguments
    if not isinstance(arguments, (list, tuple)) or len(arguments) != len(func.args):
        raise ValueError(f"{func.name} takes {len(func.args)} arguments "
                         f"({', '.join(a.name for a in func.args) or 'none'}), got "
                         f"{arguments!r}")
    out = []
    for arg_type, value in zip(func.args, arguments):
        if arg_type.name in ("unit_tags", "target_unit_tag"):
            tags = _as_sequence(value)
            tags = [value] if tags is None else tags
            indices = [_as_index(t) for t in tags]
            most = arg_type.sizes[0]
            if not 1 <= len(tags) <= most or any(i is None or i < 0 for i in indices):
                raise ValueError(f"{func.name} argument {arg_type.name!r} = {value!r} must "
                                 f"be {'a unit tag' if most == 1 else f'1 to {most} unit tags'}"
                                 " (ints >= 0)")
            out.append(indices)
        else:
            out.append(_convert_argument(func, arg_type, value))
    return FunctionCall(func.id, out)


def _lookup(function: Function | int | str) -> Function:
    if isinstance(function, Function):
        return FUNCTIONS[function.id]
    try:
        return FUNCTIONS[function]
    except KeyError as e:
        raise ValueError(
            f"unknown function {function!r}; ids are 0..{NUM_FUNCTIONS - 1} or a name "
            f"such as 'Move_screen'") from e


def _convert_argument(func: Function, arg_type: ArgumentType, value: Any) -> list[int]:
    """Returns `[v]` or `[x, y]`, checking arity and scalar range."""
    where = f"{func.name} argument {arg_type.name!r}"
    if arg_type.is_point:
        seq = _as_sequence(value)
        if seq is None or len(seq) != 2:
            raise ValueError(f"{where} must be an (x, y) point, got {value!r}")
        point = []
        for v in seq:
            index = _as_index(v)
            if index is None:
                if isinstance(v, (float, np.floating)) and np.isfinite(v):
                    index = int(np.floor(v))  # PySC2 floors points.
                else:
                    raise ValueError(f"{where} must be an (x, y) point of numbers, got {value!r}")
            point.append(index)
        limits = arg_type.sizes
        inside = limits[0] == 0 or (point[0] < limits[0] and point[1] < limits[1])
        if min(point) < 0 or not inside:
            allowed = (f"x in 0..{limits[0] - 1}, y in 0..{limits[1] - 1}" if limits[0] > 0
                       else "coordinates >= 0")
            raise ValueError(f"{where} = {value!r} is outside the allowed range: {allowed}")
        return point
    seq = _as_sequence(value)
    if seq is not None:
        if len(seq) != 1:
            raise ValueError(f"{where} takes one value, got {value!r}")
        value = seq[0]
    size = arg_type.sizes[0]
    if isinstance(value, str):
        names = [e.name for e in arg_type.values] if arg_type.values else []
        if value not in names:
            allowed = f"one of {names} or 0..{size - 1}" if names else f"an int in 0..{size - 1}"
            raise ValueError(f"{where} = {value!r} is not allowed; expected {allowed}")
        return [int(arg_type.values[value])]
    index = _as_index(value)
    if index is None or not 0 <= index < size:
        names = f" ({', '.join(e.name for e in arg_type.values)})" if arg_type.values else ""
        raise ValueError(f"{where} = {value!r} is outside the allowed range 0..{size - 1}{names}")
    return [index]


def _as_sequence(value: Any) -> Sequence[Any] | None:
    if isinstance(value, str):
        return None
    if isinstance(value, np.ndarray):
        return list(value.reshape(-1)) if value.ndim >= 1 else None
    if isinstance(value, (list, tuple)):
        return list(value)
    return None
