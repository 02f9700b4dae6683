"""sc2jax.environment: PySC2's interface tables, specs, and the environments."""

from sc2jax.environment.arguments import (
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
from sc2jax.environment.dense import DenseAction, check_dense_action, from_dense, to_dense
from sc2jax.environment.devices import over_devices
from sc2jax.environment.environments import BatchedSC2Env, SC2Env, make, to_pysc2_layout
from sc2jax.environment.features import (
    MINIMAP_FEATURES,
    SCREEN_FEATURES,
    Feature,
    FeatureType,
    PlayerRelative,
    Visibility,
    select_layers,
)
from sc2jax.environment.functions import (
    FUNCTION_ARGS_MASK,
    FUNCTIONS,
    NUM_FUNCTIONS,
    Function,
    FunctionCall,
    FunctionType,
    validate_function_call,
)
from sc2jax.environment.minigames import MAPS
from sc2jax.environment.observation_tables import (
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
from sc2jax.environment.protocol_enums import ActionResult, Alert
from sc2jax.environment.simulator import BLIZZARD_SCORE, EnvParams, Simulator
from sc2jax.environment.specs import (
    ObservationFormat,
    VariableLengthArray,
    action_spec,
    observation_spec,
)

__all__ = [name for name in dir() if not name.startswith("_")]
