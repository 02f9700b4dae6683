"""Feature layers in bytes, exactly: every layer's low byte, and a high byte for the wide ones.

Of PySC2's 38 layers, 32 hold values below 256 (scales of at most 256: categories,
ratios, densities, heights, progress). The wide ones are `unit_type` (both sets),
`unit_hit_points`, `unit_energy`, `unit_shields` and `buffs`, whose values stay below
2^16. A layer stack [..., C, y, x] is kept as

- `low`: uint8 [..., C, y, x], every layer's value mod 256, and
- `high`: uint8 [..., W, y, x], the value // 256 of the W wide layers, in channel order,

so a stack of all 27 screen and 11 minimap layers takes 44 bytes a pixel position
instead of int32's 152 (0.29 of them; a stack of narrow layers only, a quarter). The
packing is exact for values in [0, 2^16); the simulator's layers are tested to lie
there on every map.

Training trajectories and replay datasets keep their layers this way
(`pack_observation`); a network reads a packed observation as it is
(`networks.preprocessing.spatial_inputs` unpacks it inside the compiled program).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import jax.numpy as jnp

from sc2jax.environment.interface.features import Feature

BYTE_SCALE = 256
"""A layer of scale at most this holds values below 256: one byte."""
HIGH_SUFFIX = "_high"
"""The observation key of a stack's high bytes: `feature_screen_high`, ..."""
LAYER_KEYS = ("feature_screen", "feature_minimap")


def wide_channels(layers: Sequence[Feature]) -> tuple[int, ...]:
    """The channels of `layers` that need a high byte (scale above `BYTE_SCALE`)."""
    return tuple(c for c, feature in enumerate(layers) if feature.scale > BYTE_SCALE)


def pack(layers: jnp.ndarray, features: Sequence[Feature]):
    """(low uint8 [..., C, y, x], high uint8 [..., W, y, x]) of a layer stack.

    Args:
      layers: integer [..., C, y, x], C = len(features), values in [0, 2^16).
      features: the stack's layers, in channel order.
    """
    wide = list(wide_channels(features))
    low = (layers & 0xFF).astype(jnp.uint8)
    high = (layers[..., wide, :, :] >> 8).astype(jnp.uint8)
    return low, high


def unpack(low: jnp.ndarray, high: jnp.ndarray, features: Sequence[Feature]) -> jnp.ndarray:
    """The int32 layer stack [..., C, y, x] that `pack` made `low` and `high` from."""
    wide = list(wide_channels(features))
    if high.shape[-3] != len(wide):
        raise ValueError(f"high bytes have {high.shape[-3]} channels; the layers "
                         f"{[f.name for f in features]} have {len(wide)} wide ones")
    layers = jnp.asarray(low).astype(jnp.int32)
    if not wide:
        return layers
    return layers.at[..., wide, :, :].add(high.astype(jnp.int32) << 8)


def pack_observation(observation: Mapping, screen: Sequence[Feature],
                     minimap: Sequence[Feature]) -> dict:
    """An observation with its layer stacks packed: `feature_screen` and
    `feature_minimap` become uint8, beside `feature_screen_high` and
    `feature_minimap_high` (the other keys unchanged)."""
    out = dict(observation)
    for key, features in zip(LAYER_KEYS, (screen, minimap)):
        out[key], out[key + HIGH_SUFFIX] = pack(observation[key], features)
    return out


def unpacked(observation: Mapping, key: str, features: Sequence[Feature]) -> jnp.ndarray:
    """The layer stack `observation[key]`, unpacked where the observation is packed
    (it has `key + HIGH_SUFFIX`), and as it is otherwise."""
    if key + HIGH_SUFFIX not in observation:
        return jnp.asarray(observation[key])
    return unpack(jnp.asarray(observation[key]), jnp.asarray(observation[key + HIGH_SUFFIX]),
                  features)


def unpack_observation(observation: Mapping, screen: Sequence[Feature],
                       minimap: Sequence[Feature]) -> dict:
    """The inverse of `pack_observation`: the layer stacks int32, no high-byte keys."""
    out = {k: v for k, v in observation.items() if not k.endswith(HIGH_SUFFIX)}
    for key, features in zip(LAYER_KEYS, (screen, minimap)):
        out[key] = unpacked(observation, key, features)
    return out
