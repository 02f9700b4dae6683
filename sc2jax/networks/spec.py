"""`NetworkSpec`: every size a network needs, derived from the environment's specs.

Networks never hard-code input or output sizes. A `NetworkSpec` is built from an
`ObservationFormat` (which names the feature layers present, their scales and types)
and checked against the padded observation spec and the dense action spec that the
same format gives. It is a frozen, hashable dataclass, so it can be a Flax module
attribute.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from sc2jax.environment.interface.features import Feature
from sc2jax.environment.interface.functions import RAW_FUNCTIONS
from sc2jax.environment.interface.specs import ObservationFormat, action_spec, observation_spec

DEFAULT_NONSPATIAL_KEYS = ("player",)
"""Padded-observation entries fed to the non-spatial input by default: the 11 player
statistics (minerals, vespene, food, army count, ...) that a human sees on screen."""


@dataclasses.dataclass(frozen=True)
class NetworkSpec:
    """Input and output sizes of a network.

    Attributes:
      screen_layers: the screen feature layers, in `feature_screen` channel order.
      minimap_layers: the minimap feature layers, in `feature_minimap` channel order.
      screen_size: (x, y) screen resolution; `feature_screen` is [C, y, x].
      minimap_size: (x, y) minimap resolution.
      nonspatial: ((key, flat size), ...) padded-observation entries, flattened and
        concatenated into the non-spatial input vector.
      num_functions: the number of function ids (573).
      argument_sizes: for each of the 13 argument types in `TYPES` order, (x, y) for a
        point and (n,) for a scalar in [0, n); with the raw action space, for each of
        `RawAction`'s 4 arguments: `world` (x, y) the raw grid, `queued` (2,), `units`
        and `target_unit` (max_units,), a choice of `raw_units` rows.
      action_space: "features" (`FUNCTIONS`) or "raw" (`RAW_FUNCTIONS`: the raw
        networks, which read `raw_units`).
    """

    screen_layers: tuple[Feature, ...]
    minimap_layers: tuple[Feature, ...]
    screen_size: tuple[int, int]
    minimap_size: tuple[int, int]
    nonspatial: tuple[tuple[str, int], ...]
    num_functions: int
    argument_sizes: tuple[tuple[int, ...], ...]
    action_space: str = "features"

    @classmethod
    def from_format(cls, fmt: ObservationFormat,
                    nonspatial_keys: Sequence[str] = DEFAULT_NONSPATIAL_KEYS) -> NetworkSpec:
        """Builds the spec from an observation format and the specs it defines.

        Args:
          fmt: the environment's `ObservationFormat` (e.g. `env.simulator.fmt`).
          nonspatial_keys: padded-observation keys of fixed-size numeric entries to use
            as non-spatial features (e.g. "player", "game_loop", "score_cumulative",
            "available_actions_mask").

        Raises:
          TypeError: if `fmt` is not an `ObservationFormat`.
          ValueError: for an unknown or non-numeric non-spatial key.
        """
        if not isinstance(fmt, ObservationFormat):
            raise TypeError(f"fmt must be an ObservationFormat, got {type(fmt).__name__}")
        obs_spec = observation_spec(fmt, padded=True)
        act_spec = action_spec(fmt.screen_size, fmt.minimap_size)
        allowed = sorted(k for k, s in obs_spec.items()
                         if not k.startswith("feature_") and s.dtype != np.dtype(object))
        if isinstance(nonspatial_keys, str):
            raise ValueError(f"nonspatial_keys must be a sequence of keys, got {nonspatial_keys!r}")
        nonspatial = []
        for key in nonspatial_keys:
            if key not in allowed:
                raise ValueError(f"unknown non-spatial key {key!r}; allowed: {allowed}")
            nonspatial.append((key, int(np.prod(obs_spec[key].shape))))
        num_functions = int(act_spec.function.maximum) + 1
        sizes = []
        for field in act_spec[1:]:
            if field.shape == (2,):
                sizes.append((int(field.maximum[0]) + 1, int(field.maximum[1]) + 1))
            else:
                sizes.append((int(field.maximum) + 1,))
        if fmt.action_space == "raw":
            if fmt.raw_resolution is None:
                raise ValueError("a raw network needs the format's raw_resolution (the grid "
                                 "of the world point), not None (the map's own size)")
            n = fmt.max_units
            num_functions, sizes = len(RAW_FUNCTIONS), [fmt.raw_resolution, (2,), (n,), (n,)]
        screen_c, sy, sx = obs_spec["feature_screen"].shape
        minimap_c, my, mx = obs_spec["feature_minimap"].shape
        assert screen_c == len(fmt.screen_layers) and minimap_c == len(fmt.minimap_layers)
        return cls(
            screen_layers=tuple(fmt.screen_layers), minimap_layers=tuple(fmt.minimap_layers),
            screen_size=(sx, sy), minimap_size=(mx, my), nonspatial=tuple(nonspatial),
            num_functions=num_functions, argument_sizes=tuple(sizes),
            action_space=fmt.action_space)

    @property
    def nonspatial_size(self) -> int:
        return sum(size for _, size in self.nonspatial)

    @property
    def point_argument_ids(self) -> tuple[int, ...]:
        return tuple(i for i, s in enumerate(self.argument_sizes) if len(s) == 2)
