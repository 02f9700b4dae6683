"""Colours for PySC2's feature layers, as PySC2's renderer shows them.

Every layer gets a palette from its row of the feature table (`features.Feature`):

- categorical layers: a colour per value, 0 black. `player_relative` and
  `visibility_map` have PySC2's fixed colours (self green, ally yellow, neutral cyan,
  enemy red; hidden black, seen grey, visible white); two-valued layers are black and
  white; the others (`unit_type`, `player_id`, `effects`, `buffs`) get well-separated
  hues, the same value the same colour in every layer and every frame;
- scalar layers: a heat map over [0, scale), black through red and yellow to white
  (values at or above the scale are white), as PySC2's `hot` palette.

`colorize` looks values up in a palette (jittable; any leading shape), and `legend`
names the colours of a categorical layer's values for a caption.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.interface.features import Feature, PlayerRelative, Visibility

_FIXED = {
    "player_relative": {PlayerRelative.NONE: (0, 0, 0), PlayerRelative.SELF: (0, 142, 0),
                        PlayerRelative.ALLY: (255, 255, 0),
                        PlayerRelative.NEUTRAL: (129, 166, 196),
                        PlayerRelative.ENEMY: (200, 30, 30)},
    "visibility_map": {Visibility.HIDDEN: (0, 0, 0), Visibility.SEEN: (128, 128, 128),
                       Visibility.VISIBLE: (255, 255, 255)},
}
"""Layers whose values have names and fixed colours."""

_GOLDEN = 0.6180339887498949


def _hue_palette(n: int) -> np.ndarray:
    """uint8[n, 3]: value 0 black, value v a hue at v times the golden ratio around the
    colour wheel (neighbouring values far apart), at full saturation and brightness
    alternating between 1 and 0.75."""
    v = np.arange(n)
    hue = (v * _GOLDEN) % 1.0
    value = np.where(v % 2 == 0, 1.0, 0.75)
    k = (hue[:, None] * 6 + np.array([5.0, 3.0, 1.0])) % 6  # HSV to RGB at saturation 1.
    rgb = value[:, None] * (1 - np.clip(np.minimum(k, 4 - k), 0, 1))
    out = np.round(rgb * 255).astype(np.uint8)
    out[0] = 0
    return out


def _hot_palette(n: int) -> np.ndarray:
    """uint8[n + 1, 3]: black -> red -> yellow -> white over [0, n), white at n (clipped
    values)."""
    t = np.arange(n + 1) / max(n - 1, 1)
    rgb = np.clip(np.stack([3 * t, 3 * t - 1, 3 * t - 2], axis=-1), 0, 1)
    return np.round(rgb * 255).astype(np.uint8)


@functools.cache
def palette(feature: Feature) -> np.ndarray:
    """uint8[P, 3]: the colour of each value of a layer (P = scale for categorical
    layers, scale + 1 for scalar ones, the last for values at or above the scale)."""
    if feature.name in _FIXED:
        out = np.zeros((feature.scale, 3), np.uint8)
        for value, rgb in _FIXED[feature.name].items():
            out[value] = rgb
        return out
    if feature.is_categorical:
        if feature.scale == 2:
            return np.array([[0, 0, 0], [255, 255, 255]], np.uint8)
        return _hue_palette(feature.scale)
    return _hot_palette(feature.scale)


def colorize(values, feature: Feature):
    """uint8[..., 3]: the colours of a layer's values (int [...], any shape; jittable).
    Values outside the palette take its last colour (negative ones its first)."""
    table = palette(feature)
    index = jnp.clip(jnp.asarray(values, jnp.int32), 0, len(table) - 1)
    return jnp.asarray(table)[index]


def legend(feature: Feature, values, names: Mapping[int, str] | None = None
           ) -> list[tuple[int, tuple[int, int, int], str]]:
    """(value, colour, label) for each of `values` of a categorical layer, in order.

    Labels are the value's name for `player_relative` and `visibility_map`, else
    `names[value]` where given (e.g. unit type names), else the number.

    Raises:
      ValueError: for a scalar layer (its legend is the colour bar from 0 to its scale).
    """
    if not feature.is_categorical:
        raise ValueError(f"{feature.layer_set} layer {feature.name!r} is scalar; a legend "
                         f"lists a categorical layer's values")
    enum = {"player_relative": PlayerRelative, "visibility_map": Visibility}.get(feature.name)
    table = palette(feature)
    out = []
    for value in values:
        value = int(value)
        if enum is not None and value in enum._value2member_map_:
            label = enum(value).name.lower()
        else:
            label = (names or {}).get(value, str(value))
        rgb = table[min(max(value, 0), len(table) - 1)]
        out.append((value, tuple(int(c) for c in rgb), label))
    return out
