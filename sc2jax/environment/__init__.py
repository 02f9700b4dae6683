"""sc2jax.environment: PySC2's interface, the environments, the simulator and the real game.

The interface (tables, specs, dense actions) loads at once and is light. The simulator's
and the environments' names load on first use, so that `import sc2jax.networks` or
`import sc2jax.losses`, which need only the interface, do not load the simulator.

Sub-packages: `interface` (PySC2's interface as data), `engine` (the simulator),
`sc2api` (the real game's client), `server` (an SC2-API server over the engine),
`agents` (random and scripted agents); `sc2_env` holds `make` and the dm_env shells.
"""

import importlib

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
    resolve_types,
)
from sc2jax.environment.interface.dense import (
    DenseAction,
    check_dense_action,
    from_dense,
    to_dense,
)
from sc2jax.environment.interface.features import (
    MINIMAP_FEATURES,
    SCREEN_FEATURES,
    Feature,
    FeatureType,
    PlayerRelative,
    Visibility,
    select_layers,
)
from sc2jax.environment.interface.functions import (
    FUNCTION_ARGS_MASK,
    FUNCTIONS,
    NUM_FUNCTIONS,
    Function,
    FunctionCall,
    FunctionType,
    validate_function_call,
)
from sc2jax.environment.interface.layout import to_pysc2_layout
from sc2jax.environment.interface.observation_tables import (
    ControlGroup,
    FeatureUnit,
    Player,
    ProductionQueue,
    ScoreByCategory,
    ScoreByVital,
    ScoreCategories,
    ScoreCumulative,
    ScoreVitals,
    UnitLayer,
)
from sc2jax.environment.interface.protocol_enums import ActionResult, Alert
from sc2jax.environment.interface.specs import (
    ObservationFormat,
    VariableLengthArray,
    action_spec,
    observation_spec,
)

_LAZY = {
    "make": "sc2jax.environment.sc2_env",
    "SC2Env": "sc2jax.environment.sc2_env",
    "BatchedSC2Env": "sc2jax.environment.sc2_env",
    "Simulator": "sc2jax.environment.engine.simulator",
    "EnvParams": "sc2jax.environment.engine.simulator",
    "BLIZZARD_SCORE": "sc2jax.environment.engine.simulator",
    "MAPS": "sc2jax.environment.engine.minigames",
    "over_devices": "sc2jax.environment.engine.xla.devices",
}


def __getattr__(name: str):
    """Loads the simulator's and the environments' names on first use (PEP 562)."""
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


__all__ = sorted(name for name in set(globals()) | set(_LAZY)
                 if not name.startswith("_") and name != "importlib")
