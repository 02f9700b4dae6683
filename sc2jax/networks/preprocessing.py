"""Input pre-processing shared by every network (paper §4.3, "Input pre-processing").

- Categorical feature layers are embedded: a one-hot encoding over the layer's scale
  followed by a 1x1 convolution, computed as an embedding lookup (a gather), so no
  one-hot tensor is ever built (`unit_type` has 1962 categories). Layer `l` gets
  `embedding_dim(scale_l) = max(1, round(log2(scale_l)))` channels. Category 0 (no unit,
  no player, not selected, ...) starts as the zero vector (`background_zero_init`), the
  value the convolutions' zero padding gives beyond the screen's edge.
- Scalar feature layers are rescaled by `log(1 + max(x, 0))`.
- Non-spatial features (by default the 11 `player` statistics) are flattened,
  concatenated and rescaled by `log(1 + max(x, 0))`.

Spatial inputs arrive in the padded observation layout, [B, C, y, x]; outputs are
channels-last, [B, H=y, W=x, C'].
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp
from flax.linen.linear import default_embed_init

from sc2jax.environment.interface.features import Feature
from sc2jax.environment.interface.narrow import unpacked
from sc2jax.networks.spec import NetworkSpec


def embedding_dim(scale: int) -> int:
    """Channels of a categorical layer's embedding: max(1, round(log2(scale)))."""
    return max(1, int(round(math.log2(scale))))


def background_zero_init(key: jax.Array, shape: tuple[int, ...],
                         dtype=jnp.float32) -> jax.Array:
    """An embedding table [categories, D]: Flax's default draw (N(0, 1/D) entries), with
    row 0 set to zero.

    Row 0 is the background of most layers (no unit, no player, not selected). With a
    non-zero background, the convolutions' zero padding makes the screen's border
    differ from its interior: at 16x16, FullyConv's 5x5 and 3x3 convolutions mark the
    outer 3 pixels, 61% of the screen, and that artefact, not the units, dominates the
    spatial variation the spatial policy sees. With a zero background the border is
    plain ground at initialisation (the biases start at zero), and the units stand out
    (docs/results.md, "Which seeds take off").
    """
    return default_embed_init(key, shape, dtype).at[0].set(0.0)


def log_transform(x: jax.Array) -> jax.Array:
    """log(1 + max(x, 0)) as float32: the paper's logarithmic rescaling."""
    return jnp.log1p(jnp.maximum(x.astype(jnp.float32), 0.0))


def _check_batched(name: str, x: jax.Array, tail: tuple[int, ...]) -> None:
    if x.ndim != 1 + len(tail) or tuple(x.shape[1:]) != tail:
        raise ValueError(f"observation[{name!r}] has shape {tuple(x.shape)}; expected "
                         f"[B, {', '.join(map(str, tail))}] (a batch of the padded layout)")


class SpatialEncoder(nn.Module):
    """Embeds categorical layers and log-rescales scalar layers.

    Attributes:
      layers: the feature layers, in channel order.
      name_prefix: used only in error messages ("feature_screen", "feature_minimap").
    """

    layers: tuple[Feature, ...]
    name_prefix: str = "feature_screen"
    dtype: Any = jnp.float32

    @property
    def out_channels(self) -> int:
        return sum(embedding_dim(f.scale) if f.is_categorical else 1 for f in self.layers)

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        """Encodes a batch of feature layers.

        Args:
          x: [B, C, H, W] integer feature layers, C = len(layers).

        Returns:
          [B, H, W, C'] float32, C' = `out_channels`.
        """
        if x.ndim != 4 or x.shape[1] != len(self.layers):
            raise ValueError(f"{self.name_prefix} has shape {tuple(x.shape)}; expected "
                             f"[B, {len(self.layers)}, H, W]")
        x = jnp.moveaxis(x, 1, -1)  # [B, H, W, C]
        outs = []
        for c, feature in enumerate(self.layers):
            plane = x[..., c]
            if feature.is_categorical:
                table = nn.Embed(feature.scale, embedding_dim(feature.scale),
                                 embedding_init=background_zero_init, dtype=self.dtype,
                                 name=f"embed_{feature.name}")
                # Gather; clipping keeps out-of-range values (none expected) well defined.
                outs.append(table(jnp.clip(plane, 0, feature.scale - 1)))
            else:
                outs.append(log_transform(plane)[..., None].astype(self.dtype))
        return jnp.concatenate(outs, axis=-1)


def nonspatial_features(spec: NetworkSpec, obs: Mapping[str, jax.Array]) -> jax.Array:
    """The log-rescaled non-spatial input vector.

    Args:
      spec: names the keys and their flat sizes.
      obs: padded observations with a leading batch dim [B, ...].

    Returns:
      [B, spec.nonspatial_size] float32.
    """
    parts = []
    for key, size in spec.nonspatial:
        if key not in obs:
            raise ValueError(f"observation has no {key!r}; the network needs {spec.nonspatial}")
        value = jnp.asarray(obs[key])
        flat = value.reshape(value.shape[0], -1) if value.ndim else value.reshape(1, -1)
        if flat.shape[1] != size:
            raise ValueError(f"observation[{key!r}] has shape {tuple(value.shape)}; expected "
                             f"[B, ...] with {size} values per example")
        parts.append(log_transform(flat))
    return jnp.concatenate(parts, axis=-1)


def spatial_inputs(spec: NetworkSpec, obs: Mapping[str, jax.Array]) -> tuple[jax.Array, jax.Array]:
    """Checks and returns (feature_screen, feature_minimap), each [B, C, y, x], unpacked
    from bytes where the observation is packed (`environment.interface.narrow`)."""
    for key in ("feature_screen", "feature_minimap", "available_actions_mask"):
        if key not in obs:
            raise ValueError(f"observation has no {key!r}; keys present: {sorted(obs)}")
    (sx, sy), (mx, my) = spec.screen_size, spec.minimap_size
    screen = unpacked(obs, "feature_screen", spec.screen_layers)
    minimap = unpacked(obs, "feature_minimap", spec.minimap_layers)
    _check_batched("feature_screen", screen, (len(spec.screen_layers), sy, sx))
    _check_batched("feature_minimap", minimap, (len(spec.minimap_layers), my, mx))
    return screen, minimap
