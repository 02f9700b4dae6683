"""PySC2's observation layout and the padded layout of batched environments.

The padded layout (`specs.observation_spec(fmt, padded=True)`) gives every observation a
fixed shape, so that batches stack, and the available functions as a bool mask of 573
named `available_actions_mask`; PySC2's layout trims variable-length lists to their
entries and gives `available_actions` as a list of ids, as PySC2 does. One name, one
meaning: `FUNCTIONS.x.id in obs["available_actions"]` is right wherever that key
exists. `named` gives PySC2's layout named access, as PySC2 does
(`obs["feature_screen"].player_relative`).
"""

from __future__ import annotations

import numpy as np

from sc2jax.environment.interface import observation_tables as tables
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.functions import NUM_FUNCTIONS
from sc2jax.environment.interface.named import NamedDict, NamedNumpyArray

MASK = "available_actions_mask"
"""The padded layouts' name for the available functions as a mask [573] (bool)."""
_UNIT_ROW_KEYS = ("single_select", "multi_select", "build_queue", "cargo", "feature_units",
                  "raw_units")


def to_pysc2_layout(padded: dict, map_name: str, raw: bool = False) -> dict:
    """Converts one padded observation (numpy) to PySC2's layout: variable-length lists
    trimmed to their entries, the mask as `available_actions`, a list of ids (none for
    agents of the `raw` action space, as PySC2 gives them), plus `map_name`."""
    out = dict(padded)
    for key in _UNIT_ROW_KEYS:
        if key in out:
            out[key] = out[key][out[key][:, 0] != 0]
    for key in ("feature_units", "raw_units"):
        if key in out:
            out[key] = out[key].astype(np.int64)
    out["production_queue"] = out["production_queue"][out["production_queue"][:, 0] != 0]
    out["last_actions"] = out["last_actions"][out["last_actions"] >= 0]
    for key in ("action_result", "alerts", "upgrades"):
        out[key] = out[key][out[key] != 0]
    mask = out.pop(MASK)
    if not raw:
        out["available_actions"] = np.flatnonzero(mask).astype(np.int32)
    out["map_name"] = map_name
    return out


_UNIT_ROWS = (None, tables.UnitLayer)
_NAMES = {
    "player": (tables.Player,),
    "score_cumulative": (tables.ScoreCumulative,),
    "score_by_category": (tables.ScoreByCategory, tables.ScoreCategories),
    "score_by_vital": (tables.ScoreByVital, tables.ScoreVitals),
    "single_select": _UNIT_ROWS, "multi_select": _UNIT_ROWS, "build_queue": _UNIT_ROWS,
    "cargo": _UNIT_ROWS,
    "production_queue": (None, tables.ProductionQueue),
    "control_groups": (None, tables.ControlGroup),
    "feature_units": (None, tables.FeatureUnit),
    "raw_units": (None, tables.FeatureUnit),
}
"""The names of each observation's dimensions, beside the feature layers'."""


def named(obs: dict, fmt: specs.ObservationFormat) -> NamedDict:
    """One observation in PySC2's layout with PySC2's names: a `NamedDict` of
    `NamedNumpyArray`s. The layers are named by the format's own layers (so
    `feature_screen.player_relative` is right with any subset of layers); the tables by
    `observation_tables`' enums; the unit rows' columns by `UnitLayer` or `FeatureUnit`.
    The arrays are views of `obs`'s."""
    layers = {"feature_screen": ([f.name for f in fmt.screen_layers],),
              "feature_minimap": ([f.name for f in fmt.minimap_layers],)}
    out = NamedDict()
    for key, value in obs.items():
        names = layers.get(key) or _NAMES.get(key)
        out[key] = value if isinstance(value, str) else NamedNumpyArray(value, names or ())
    return out


def available_mask(ids) -> np.ndarray:
    """PySC2's `available_actions` (function ids) as the padded layouts' mask, bool [573]."""
    mask = np.zeros(NUM_FUNCTIONS, bool)
    mask[np.asarray(ids)] = True
    return mask


def to_padded_layout(obs: dict, fmt: specs.ObservationFormat) -> dict:
    """Converts one observation in PySC2's layout back to the padded layout (the inverse
    of `to_pysc2_layout`; `map_name` is dropped), e.g. for the real game's observations
    in a batch.

    Raises:
      ValueError: if a list is longer than the padded layout holds.
    """
    out = {}
    for key, spec in specs.observation_spec(fmt, padded=True).items():
        if key == MASK:
            out[key] = available_mask(obs["available_actions"])
            continue
        value = np.asarray(obs[key])
        if value.shape != spec.shape:
            if value.shape[0] > spec.shape[0] or value.shape[1:] != spec.shape[1:]:
                raise ValueError(f"observation {key!r} of shape {value.shape} does not fit "
                                 f"the padded shape {spec.shape}")
            fill = -1 if key == "last_actions" else 0
            padded = np.full(spec.shape, fill, spec.dtype)
            padded[:value.shape[0]] = value
            value = padded
        out[key] = value.astype(spec.dtype, copy=False)
    return out
