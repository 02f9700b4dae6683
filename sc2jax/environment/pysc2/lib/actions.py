"""PySC2's `pysc2.lib.actions`: the 573 functions, their 13 argument types and the enums
of their scalar arguments."""

from typing import NamedTuple

from sc2jax.environment.interface.arguments import (
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
    Function,
    FunctionCall,
    Functions,
    FunctionType,
)


class ValidActions(NamedTuple):
    """An agent's action spec: the argument types at the agent's resolutions, and the
    functions with their arguments of those types."""

    types: Arguments
    functions: Functions


__all__ = ["FUNCTIONS", "TYPES", "Arguments", "ArgumentType", "ControlGroupAct", "Function",
           "FunctionCall", "FunctionType", "Functions", "Queued", "SelectAdd",
           "SelectPointAct", "SelectUnitAct", "SelectWorker", "ValidActions"]
