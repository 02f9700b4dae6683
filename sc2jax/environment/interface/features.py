"""The spatial feature layers of PySC2 v4: 27 screen layers and 11 minimap layers.

Each layer has PySC2's index, name, scale (values lie in `[0, scale)`) and type.
`SCREEN_FEATURES.player_relative` is a `Feature`; `select_layers` picks a subset by
name, in the order asked for.
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from typing import NamedTuple

UNIT_TYPE_SCALE = 1962
"""max(static_data.UNIT_TYPES) + 1 in PySC2 v4."""

BUFFS_SCALE = 290
"""max(static_data.BUFFS) + 1 in PySC2 v4."""
DENSITY = {"unit_density": (1, 15), "unit_density_aa": (16, 255)}
"""Density layer -> (multiplier, cap) applied to the number of units at a pixel."""


class FeatureType(enum.Enum):
    SCALAR = 1
    CATEGORICAL = 2


class Feature(NamedTuple):
    """One feature layer.

    Attributes:
      index: PySC2's index within its layer set.
      name: PySC2's name.
      layer_set: "screen" or "minimap".
      scale: values lie in `[0, scale)` (scalar layers may exceed it; PySC2 clips only
        when colouring).
      type: SCALAR or CATEGORICAL.
    """

    index: int
    name: str
    layer_set: str
    scale: int
    type: FeatureType

    @property
    def is_categorical(self) -> bool:
        return self.type is FeatureType.CATEGORICAL


_S, _C = FeatureType.SCALAR, FeatureType.CATEGORICAL

_SCREEN = (
    ("height_map", 256, _S),
    ("visibility_map", 4, _C),
    ("creep", 2, _C),
    ("power", 2, _C),
    ("player_id", 17, _C),
    ("player_relative", 5, _C),
    ("unit_type", UNIT_TYPE_SCALE, _C),
    ("selected", 2, _C),
    ("unit_hit_points", 1600, _S),
    ("unit_hit_points_ratio", 256, _S),
    ("unit_energy", 1000, _S),
    ("unit_energy_ratio", 256, _S),
    ("unit_shields", 1000, _S),
    ("unit_shields_ratio", 256, _S),
    ("unit_density", 16, _S),
    ("unit_density_aa", 256, _S),
    ("effects", 16, _C),
    ("hallucinations", 2, _C),
    ("cloaked", 2, _C),
    ("blip", 2, _C),
    ("buffs", BUFFS_SCALE, _C),
    ("buff_duration", 256, _S),
    ("active", 2, _C),
    ("build_progress", 256, _S),
    ("pathable", 2, _C),
    ("buildable", 2, _C),
    ("placeholder", 2, _C),
)

_MINIMAP = (
    ("height_map", 256, _S),
    ("visibility_map", 4, _C),
    ("creep", 2, _C),
    ("camera", 2, _C),
    ("player_id", 17, _C),
    ("player_relative", 5, _C),
    ("selected", 2, _C),
    ("unit_type", UNIT_TYPE_SCALE, _C),
    ("alerts", 2, _C),
    ("pathable", 2, _C),
    ("buildable", 2, _C),
)

ScreenFeatures = NamedTuple("ScreenFeatures", [(name, Feature) for name, _, _ in _SCREEN])
MinimapFeatures = NamedTuple("MinimapFeatures", [(name, Feature) for name, _, _ in _MINIMAP])

SCREEN_FEATURES = ScreenFeatures(*(
    Feature(i, name, "screen", scale, kind) for i, (name, scale, kind) in enumerate(_SCREEN)))
MINIMAP_FEATURES = MinimapFeatures(*(
    Feature(i, name, "minimap", scale, kind) for i, (name, scale, kind) in enumerate(_MINIMAP)))


class PlayerRelative(enum.IntEnum):
    """Values of the `player_relative` layers."""

    NONE = 0
    SELF = 1
    ALLY = 2
    NEUTRAL = 3
    ENEMY = 4


class Visibility(enum.IntEnum):
    """Values of the `visibility_map` layers."""

    HIDDEN = 0
    SEEN = 1
    VISIBLE = 2


def select_layers(feature_set: ScreenFeatures | MinimapFeatures,
                  names: Sequence[str] | None) -> tuple[Feature, ...]:
    """Returns the layers named, in the order given; all of them if `names` is None.

    Args:
      feature_set: `SCREEN_FEATURES` or `MINIMAP_FEATURES`.
      names: layer names, e.g. `("player_relative", "selected")`.

    Raises:
      ValueError: for an unknown or repeated name, or an empty list.
    """
    if names is None:
        return tuple(feature_set)
    if isinstance(names, str):
        raise ValueError(f"layer names must be a sequence of names, got the string {names!r}")
    names = tuple(names)
    layer_set = feature_set[0].layer_set
    if not names:
        raise ValueError(f"asked for no {layer_set} layers; give at least one, or None for all")
    allowed = feature_set._fields
    for name in names:
        if name not in allowed:
            raise ValueError(f"unknown {layer_set} layer {name!r}; allowed: {list(allowed)}")
    if len(set(names)) != len(names):
        raise ValueError(f"{layer_set} layer names repeat: {list(names)}")
    return tuple(getattr(feature_set, name) for name in names)
