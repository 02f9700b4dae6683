"""PySC2's unit rows (`feature_units`, `raw_units`) from per-unit values.

The simulator (jax, under jit) and the SC2-API client (numpy, on the game's
`raw_data.units`) both build their rows here, with the same float32 arithmetic, so
they give the same rows for the same values.
"""

from __future__ import annotations

import jax.numpy as jnp

from sc2jax.environment.interface import observation_tables as tables
from sc2jax.environment.interface.camera import Camera, RawGrid, array_module
from sc2jax.environment.interface.functions import RAW_FUNCTION_OF_ABILITY


def ratio_255(value, maximum):
    """int32: value / maximum mapped to 0..255 (0 where maximum is 0). Jittable, or numpy
    for numpy inputs (the same float32 arithmetic)."""
    xp = array_module(value)
    return xp.where(maximum > 0, (value / xp.maximum(maximum, 1e-6) * 255), 0).astype(xp.int32)


def _feature_unit_rows(api: dict, pixel_pos, pixel_radius, with_tags: bool, dtype):
    """[N, 46] `FeatureUnit` rows from `api_units`-style values, by PySC2's rules:
    coordinates and radii in pixels, ratios 0..255, progress in percent, tags only
    `with_tags`; `order_id_k` the raw function of order k's ability
    (`RAW_FUNCTION_OF_ABILITY` of `order_ability_k`); columns missing from `api` are 0."""
    xp = array_module(api["unit_type"])
    zeros = xp.zeros(api["unit_type"].shape, dtype)
    table = xp.asarray(RAW_FUNCTION_OF_ABILITY)
    order_ids = {f"order_id_{k}": table[xp.clip(api[f"order_ability_{k}"], 0, len(table) - 1)]
                 for k in range(4) if f"order_ability_{k}" in api}
    computed = {
        **order_ids,
        "build_progress": api["build_progress"] * 100,
        "health_ratio": ratio_255(api["health"], api["health_max"]),
        "shield_ratio": ratio_255(api["shield"], api["shield_max"]),
        "energy_ratio": ratio_255(api["energy"], api["energy_max"]),
        "x": xp.floor(pixel_pos[:, 0]),
        "y": xp.floor(pixel_pos[:, 1]),
        "radius": pixel_radius,
        "tag": api["tag"] if with_tags else zeros,
        "order_progress_0": api.get("order_progress_0", zeros) * 100,
        "order_progress_1": api.get("order_progress_1", zeros) * 100,
    }
    return xp.stack([computed.get(f.name, api.get(f.name, zeros)).astype(dtype)
                     for f in tables.FeatureUnit], axis=-1)


def _world_pos(api: dict):
    return array_module(api["x"]).stack([api["x"], api["y"]], axis=-1)


def screen_unit_rows(api: dict, camera: Camera, center, dtype=jnp.int32):
    """[N, 46] `feature_units` rows of every unit in `api` (`api_units`-style values),
    in the screen pixels of `camera` centred at `center` (world x, y), without tags.

    The simulator (jax) and the SC2-API client (numpy, on the game's `raw_data.units`)
    both build their rows here, with the same float32 arithmetic, so they give the same
    rows for the same values.
    """
    return _feature_unit_rows(api, camera.world_to_pixel(center, _world_pos(api)),
                              api["radius"] * camera.pixels_per_unit, False, dtype)


def raw_unit_rows(api: dict, grid: RawGrid, dtype=jnp.int32):
    """[N, 46] `raw_units` rows of every unit in `api`, in the pixels of the raw `grid`,
    with tags (as `screen_unit_rows`)."""
    return _feature_unit_rows(api, grid.world_to_pixel(_world_pos(api)),
                              api["radius"] * grid.pixels_per_unit, True, dtype)
