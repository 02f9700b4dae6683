"""dm_env specs for observations and actions, derived from the interface tables.

Two observation layouts share these specs:

- **PySC2 layout** (`padded=False`): what the single `dm_env` environment returns,
  with PySC2 v4's keys, dtypes and shapes. Lists whose length varies (`multi_select`,
  `available_actions`, ...) have a `VariableLengthArray` spec: any leading length up
  to the maximum.
- **Padded layout** (`padded=True`): what the functional simulator and the batched
  environment return, every shape fixed so it can be jitted and vmapped. Unit
  lists are padded with zero rows (no real unit has type 0), `last_actions` with
  -1, `action_result` and `alerts` with 0, the available functions are a boolean mask
  over all function ids named `available_actions_mask` (not PySC2's `available_actions`,
  a list of ids; with `action_space="raw"` a mask over the 564 `RAW_FUNCTIONS`, which
  PySC2 does not give), and `feature_units`/`raw_units` are int32 (JAX runs without x64).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from dm_env import specs

from sc2jax.environment.interface import observation_tables as tables
from sc2jax.environment.interface.arguments import Size, normalize_size, resolve_types
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES, select_layers
from sc2jax.environment.interface.functions import NUM_FUNCTIONS, RAW_FUNCTIONS

MIN_RESOLUTION = 16
MAX_RESOLUTION = 256
ACTION_SPACES = ("features", "raw")


class VariableLengthArray(specs.Array):
    """An array spec whose leading dimension may be anything from 0 to `shape[0]`."""

    def validate(self, value: Any) -> np.ndarray:
        value = np.asarray(value)
        if value.ndim != len(self.shape) or value.shape[1:] != self.shape[1:] or (
                value.shape[0] > self.shape[0]):
            self._fail_validation(
                f"Expected shape (n<={self.shape[0]}, {', '.join(map(str, self.shape[1:]))}) "
                f"but found {value.shape}")
        if value.dtype != self.dtype:
            self._fail_validation(f"Expected dtype {self.dtype} but found {value.dtype}")
        return value

    def generate_value(self) -> np.ndarray:
        return np.zeros((0,) + self.shape[1:], self.dtype)


class StringSpec(specs.Array):
    """A spec for a Python string (PySC2's `map_name`)."""

    def __init__(self, name: str | None = None):
        super().__init__((), np.dtype(object), name)

    def validate(self, value: Any) -> Any:
        if not isinstance(value, str):
            self._fail_validation(f"Expected a str but found {type(value).__name__}")
        return value

    def generate_value(self) -> str:
        return ""


@dataclasses.dataclass(frozen=True)
class ObservationFormat:
    """What the agent observes: resolutions, layers and optional unit lists.

    Attributes:
      screen_size: feature-screen resolution, an int or (x, y); 16..256.
      minimap_size: feature-minimap resolution, an int or (x, y); 16..256.
      screen_features: screen layer names to render, in order; None for all 27.
      minimap_features: minimap layer names to render, in order; None for all 11.
      use_feature_units: add `feature_units` (on-screen units, 46 fields).
      use_raw_units: add `raw_units` (all visible units, 46 fields).
      max_units: rows of padded unit lists (`feature_units`, `raw_units`, `multi_select`).
      raw_resolution: the raw grid's resolution, an int or (x, y) (`camera.RawGrid`:
        `raw_units` x, y and the raw actions' `world` point); None for the map's size
        (PySC2's default).
      action_space: "features" (PySC2's `FUNCTIONS` on the feature layers: `DenseAction`)
        or "raw" (PySC2's `RAW_FUNCTIONS`: `raw.RawAction`; needs `use_raw_units`, as
        PySC2's `ActionSpace.RAW`).
    """

    screen_size: Size = 64
    minimap_size: Size = 64
    screen_features: Sequence[str] | None = None
    minimap_features: Sequence[str] | None = None
    use_feature_units: bool = False
    use_raw_units: bool = False
    max_units: int = 64
    raw_resolution: Size | None = None
    action_space: str = "features"

    def __post_init__(self):
        for name in ("screen_size", "minimap_size"):
            object.__setattr__(self, name, normalize_size(
                getattr(self, name), name, MIN_RESOLUTION, MAX_RESOLUTION))
        for name, table in (("screen_features", SCREEN_FEATURES),
                            ("minimap_features", MINIMAP_FEATURES)):
            names = getattr(self, name)
            if names is not None:
                object.__setattr__(self, name, tuple(f.name for f in select_layers(table, names)))
        if not isinstance(self.max_units, int) or self.max_units < 1:
            raise ValueError(f"max_units must be a positive int, got {self.max_units!r}")
        if self.raw_resolution is not None:
            object.__setattr__(self, "raw_resolution", normalize_size(
                self.raw_resolution, "raw_resolution", 1, 4096))
        if self.action_space not in ACTION_SPACES:
            raise ValueError(f"action_space must be one of {ACTION_SPACES}, got "
                             f"{self.action_space!r}")
        if self.action_space == "raw" and not self.use_raw_units:
            raise ValueError("action_space='raw' needs use_raw_units=True (the raw actions "
                             "name units by their raw_units rows), as PySC2's does")

    @property
    def screen_layers(self):
        return select_layers(SCREEN_FEATURES, self.screen_features)

    @property
    def minimap_layers(self):
        return select_layers(MINIMAP_FEATURES, self.minimap_features)

    def screen_index(self, name: str) -> int:
        """The index of screen layer `name` in this format's `feature_screen` (PySC2's
        `SCREEN_FEATURES.<name>.index` holds only with all 27 layers).

        Raises:
          ValueError: for a layer this format does not render, naming those it does.
        """
        return _layer_index(self.screen_layers, name, "screen")

    def minimap_index(self, name: str) -> int:
        """The index of minimap layer `name` in this format's `feature_minimap`."""
        return _layer_index(self.minimap_layers, name, "minimap")

    @property
    def types(self):
        """The argument types resolved to this format's resolutions."""
        return resolve_types(self.screen_size, self.minimap_size)


def _layer_index(layers, name: str, layer_set: str) -> int:
    names = [layer.name for layer in layers]
    if name not in names:
        raise ValueError(f"{layer_set} layer {name!r} is not in this format; it has {names}")
    return names.index(name)


# Maximum lengths of PySC2's variable-length fields, and their padded lengths.
MAX_BUILD_QUEUE = 8
MAX_CARGO = 8
MAX_ALERTS = 4
MAX_LAST_ACTIONS = 4
MAX_UPGRADES = 64


def observation_spec(fmt: ObservationFormat = ObservationFormat(), *,
                     padded: bool = False) -> dict[str, specs.Array]:
    """Returns the observation spec, a dict of dm_env specs keyed as in PySC2 v4.

    Args:
      fmt: resolutions, layers and unit lists.
      padded: the padded layout of the simulator and batched environment (True) or
        PySC2's layout (False); see the module docstring.
    """
    (sx, sy), (mx, my) = fmt.screen_size, fmt.minimap_size
    unit = len(tables.UnitLayer)

    def array(name, shape, dtype=np.int32):
        return specs.Array(tuple(shape), np.dtype(dtype), name=name)

    def variable(name, max_len, tail=(), dtype=np.int32):
        if padded:
            return array(name, (max_len,) + tuple(tail), dtype)
        return VariableLengthArray((max_len,) + tuple(tail), np.dtype(dtype), name=name)

    out = {
        "feature_screen": array("feature_screen", (len(fmt.screen_layers), sy, sx)),
        "feature_minimap": array("feature_minimap", (len(fmt.minimap_layers), my, mx)),
        "player": array("player", (len(tables.Player),)),
        "game_loop": array("game_loop", (1,)),
        "score_cumulative": array("score_cumulative", (len(tables.ScoreCumulative),)),
        "score_by_category": array(
            "score_by_category", (len(tables.ScoreByCategory), len(tables.ScoreCategories))),
        "score_by_vital": array(
            "score_by_vital", (len(tables.ScoreByVital), len(tables.ScoreVitals))),
        "single_select": variable("single_select", 1, (unit,)),
        "multi_select": variable("multi_select", fmt.max_units, (unit,)),
        "build_queue": variable("build_queue", MAX_BUILD_QUEUE, (unit,)),
        "production_queue": variable(
            "production_queue", MAX_BUILD_QUEUE, (len(tables.ProductionQueue),)),
        "cargo": variable("cargo", MAX_CARGO, (unit,)),
        "cargo_slots_available": array("cargo_slots_available", (1,)),
        "control_groups": array(
            "control_groups", (tables.NUM_CONTROL_GROUPS, len(tables.ControlGroup))),
        "last_actions": variable("last_actions", MAX_LAST_ACTIONS),
        "action_result": variable("action_result", MAX_LAST_ACTIONS),
        "alerts": variable("alerts", MAX_ALERTS),
        "upgrades": variable("upgrades", MAX_UPGRADES),
        "home_race_requested": array("home_race_requested", (1,)),
        "away_race_requested": array("away_race_requested", (1,)),
    }
    if padded:
        out["available_actions_mask"] = specs.BoundedArray(
            (len(RAW_FUNCTIONS) if fmt.action_space == "raw" else NUM_FUNCTIONS,), np.bool_,
            False, True, name="available_actions_mask")
    else:
        if fmt.action_space != "raw":  # PySC2 gives raw agents none.
            out["available_actions"] = VariableLengthArray(
                (NUM_FUNCTIONS,), np.dtype(np.int32), name="available_actions")
        out["map_name"] = StringSpec(name="map_name")
    # PySC2 gives the unit lists as int64; JAX (without x64) computes them as int32.
    units_dtype = np.int32 if padded else np.int64
    if fmt.use_feature_units:
        out["feature_units"] = variable(
            "feature_units", fmt.max_units, (len(tables.FeatureUnit),), units_dtype)
    if fmt.use_raw_units:
        out["raw_units"] = variable(
            "raw_units", fmt.max_units, (len(tables.FeatureUnit),), units_dtype)
    return out


def action_spec(screen_size: Size = 64, minimap_size: Size = 64) -> DenseAction:
    """Returns the dense action spec: a `DenseAction` of `BoundedArray`s (no batch dim).

    Points are (x, y) with x in `[0, x_size)` and y in `[0, y_size)`.
    """
    types = resolve_types(screen_size, minimap_size)
    fields = [specs.BoundedArray((), np.int32, 0, NUM_FUNCTIONS - 1, name="function")]
    for t in types:
        if t.is_point:
            fields.append(specs.BoundedArray(
                (2,), np.int32, (0, 0), (t.sizes[0] - 1, t.sizes[1] - 1), name=t.name))
        else:
            fields.append(specs.BoundedArray((), np.int32, 0, t.sizes[0] - 1, name=t.name))
    return DenseAction(*fields)

