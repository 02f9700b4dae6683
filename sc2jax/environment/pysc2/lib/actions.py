"""PySC2's `pysc2.lib.actions`: the 573 functions, their 13 argument types and the enums
of their scalar arguments; the 564 raw functions and their 4 argument types; the action
spaces."""

import enum
from typing import NamedTuple

from sc2jax.environment.interface.arguments import (
    RAW_TYPES,
    TYPES,
    Arguments,
    ArgumentType,
    ControlGroupAct,
    Queued,
    SelectAdd,
    SelectPointAct,
    SelectUnitAct,
    SelectWorker,
)
from sc2jax.environment.interface.functions import (
    FUNCTIONS,
    RAW_FUNCTIONS,
    Function,
    FunctionCall,
    Functions,
    FunctionType,
)


class ActionSpace(enum.Enum):
    """How an agent acts (the simulator has no RGB observations)."""

    FEATURES = 1
    RGB = 2
    RAW = 3


class ValidActions(NamedTuple):
    """An agent's action spec: the argument types at the agent's resolutions, and the
    functions with their arguments of those types."""

    types: Arguments
    functions: Functions


__all__ = ["FUNCTIONS", "RAW_FUNCTIONS", "RAW_TYPES", "TYPES", "ActionSpace",
           "Arguments", "ArgumentType", "ControlGroupAct", "Function", "FunctionCall",
           "FunctionType", "Functions", "Queued", "SelectAdd", "SelectPointAct",
           "SelectUnitAct", "SelectWorker", "ValidActions"]
