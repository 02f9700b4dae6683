"""Raw FullyConv: FullyConv's design on the raw interface (`action_space="raw"`).

The raw interface names units by their `raw_units` rows and points by the raw grid,
so the network reads the unit list, not the screen:

- **Units.** Each row of `raw_units` [B, N, 46] is encoded by two dense layers of 64
  (ReLU) from its unit type, alliance, first order and add-on (embedded as the feature
  layers' categories are) and its other fields (log-rescaled; x and y as fractions of
  the grid).
- **The grid.** The unit encodings are summed into the pixel of the raw grid each unit
  stands on (a scatter), and FullyConv's stack (conv 16 5x5, conv 32 3x3, ReLU) runs on
  that map, so that the spatial head sees where units are.
- **The minimap.** FullyConv's minimap branch, as in FullyConv.
- **The state.** A dense layer of 256 (ReLU) on the flattened grid and minimap outputs,
  the units' masked mean and max, and the non-spatial features.

Heads: the value, the raw function (564, masked by availability) and `queued` from the
state; `world` from a 1x1 convolution of the grid output, the scattered unit encodings
and the broadcast non-spatial features (a softmax over the grid's pixels, as
FullyConv's point heads);
the commanded rows (`units`, one Bernoulli logit each) and the target row (one softmax
over the rows) from a dense layer on each row's encoding joined with the state. The
policy over these outputs is `raw_policy`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.environment.interface.features import UNIT_TYPE_SCALE
from sc2jax.environment.interface.functions import RAW_FUNCTIONS
from sc2jax.environment.interface.observation_tables import FeatureUnit
from sc2jax.networks.fully_conv import FullyConvStack
from sc2jax.networks.heads import broadcast_vector, pixel_logits
from sc2jax.networks.outputs import as_float32
from sc2jax.networks.preprocessing import (
    SpatialEncoder,
    background_zero_init,
    embedding_dim,
    log_transform,
    nonspatial_features,
    spatial_inputs,
)
from sc2jax.networks.raw_policy import RawNetworkOutput
from sc2jax.networks.spec import NetworkSpec

UNIT_EMBEDDING = 64
"""The width of each unit row's encoding."""

_CATEGORIES = {FeatureUnit.unit_type: UNIT_TYPE_SCALE, FeatureUnit.alliance: 5,
               FeatureUnit.order_id_0: len(RAW_FUNCTIONS),
               FeatureUnit.addon_unit_type: UNIT_TYPE_SCALE}
"""The unit fields embedded as categories, and their sizes."""
_SKIPPED = (FeatureUnit.tag, FeatureUnit.x, FeatureUnit.y, FeatureUnit.order_id_1,
            FeatureUnit.order_id_2, FeatureUnit.order_id_3, FeatureUnit.buff_id_0,
            FeatureUnit.buff_id_1)
"""Unit fields not read as numbers: the tag (a name), the position (read as a fraction
of the grid), later orders and buffs (categories of little use to a Terran player)."""
_NUMERIC = tuple(f for f in FeatureUnit if f not in _CATEGORIES and f not in _SKIPPED)


class UnitEncoder(nn.Module):
    """Encodes `raw_units` rows: [B, N, 46] -> [B, N, UNIT_EMBEDDING]."""

    grid: tuple[int, int]
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, rows: jax.Array) -> jax.Array:
        parts = []
        for field, size in _CATEGORIES.items():
            table = nn.Embed(size, embedding_dim(size), embedding_init=background_zero_init,
                             dtype=self.dtype, name=f"embed_{field.name}")
            parts.append(table(jnp.clip(rows[..., field], 0, size - 1)))
        parts.append(log_transform(rows[..., jnp.asarray(_NUMERIC)]).astype(self.dtype))
        xy = rows[..., jnp.asarray([FeatureUnit.x, FeatureUnit.y])].astype(jnp.float32)
        parts.append((xy / jnp.asarray(self.grid, jnp.float32)).astype(self.dtype))
        x = jnp.concatenate(parts, axis=-1)
        x = nn.relu(nn.Dense(UNIT_EMBEDDING, dtype=self.dtype, name="fc1")(x))
        return nn.relu(nn.Dense(UNIT_EMBEDDING, dtype=self.dtype, name="fc2")(x))


def scatter_units(encoding: jax.Array, rows: jax.Array, real: jax.Array,
                  grid: tuple[int, int]) -> jax.Array:
    """Sums each real row's encoding into the grid pixel of its (x, y).

    Args:
      encoding: [B, N, D].
      rows: [B, N, 46] the `raw_units` rows (x, y on the grid).
      real: bool [B, N].
      grid: (X, Y).

    Returns:
      [B, Y, X, D].
    """
    b, _, d = encoding.shape
    gx, gy = grid
    x = jnp.clip(rows[..., FeatureUnit.x], 0, gx - 1)
    y = jnp.clip(rows[..., FeatureUnit.y], 0, gy - 1)
    pixel = jnp.where(real, y * gx + x, gx * gy)  # Padding rows fall off the end.
    out = jnp.zeros((b, gx * gy, d), encoding.dtype)
    out = out.at[jnp.arange(b)[:, None], pixel].add(encoding, mode="drop")
    return out.reshape(b, gy, gx, d)


class RawFullyConv(nn.Module):
    """FullyConv on the raw interface (module docstring).

    Attributes:
      spec: input and output sizes, of a raw format (`spec.action_space == "raw"`).
      hidden: units of the fully-connected layer (256, as FullyConv's).
      dtype: the computation dtype (`COMPUTE_DTYPES`).
    """

    spec: NetworkSpec
    hidden: int = 256
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, obs: Mapping[str, jax.Array], action: Any = None) -> RawNetworkOutput:
        """Runs the network on a batch of padded observations.

        Args:
          obs: padded observations with a batch dim: raw_units [B, N, 46],
            feature_minimap [B, Cm, Ym, Xm], available_actions_mask [B, 564], and the
            spec's non-spatial keys.
          action: ignored (independent heads).

        Returns:
          `RawNetworkOutput`: value [B], function_logits [B, 564], world `PixelLogits`
          [B, X*Y] over the raw grid, queued [B, 2], units and target [B, N].
        """
        del action
        if self.spec.action_space != "raw":
            raise ValueError("RawFullyConv needs a raw spec (a format with "
                             "action_space='raw'); got a features spec")
        grid = self.spec.argument_sizes[0]
        num_rows = self.spec.argument_sizes[2][0]
        if "raw_units" not in obs:
            raise ValueError(f"observation has no 'raw_units'; keys present: {sorted(obs)}")
        rows = jnp.asarray(obs["raw_units"])
        if rows.ndim != 3 or rows.shape[1:] != (num_rows, len(FeatureUnit)):
            raise ValueError(f"raw_units has shape {rows.shape}; expected "
                             f"[B, {num_rows}, {len(FeatureUnit)}]")
        _, minimap = spatial_inputs(self.spec, obs)
        real = rows[..., FeatureUnit.unit_type] != 0
        own = real & (rows[..., FeatureUnit.alliance] == 1)
        encoding = UnitEncoder(grid, self.dtype, name="units")(rows)
        m = FullyConvStack(self.dtype, name="minimap_conv")(
            SpatialEncoder(self.spec.minimap_layers, "feature_minimap", self.dtype,
                           name="minimap_embed")(minimap))
        scattered = scatter_units(encoding, rows, real, grid)
        g = FullyConvStack(self.dtype, name="grid_conv")(scattered)
        ns = nonspatial_features(self.spec, obs).astype(self.dtype)
        weights = real[..., None].astype(self.dtype)
        mean = jnp.sum(encoding * weights, axis=1) / jnp.maximum(jnp.sum(weights, axis=1), 1)
        largest = jnp.max(jnp.where(real[..., None], encoding, 0), axis=1)
        b = rows.shape[0]
        h = nn.relu(nn.Dense(self.hidden, dtype=self.dtype, name="fc")(jnp.concatenate(
            [g.reshape(b, -1), m.reshape(b, -1), mean, largest, ns], axis=-1)))
        # The units' encodings beside the convolutions' output: training can switch every
        # ReLU of the convolutions off on so sparse a map (docs/results.md), and the
        # encodings keep each unit's pixel in the world head's view.
        state = jnp.concatenate([g, scattered, broadcast_vector(ns, g.shape[1], g.shape[2])],
                                axis=-1)
        per_row = jnp.concatenate(
            [encoding, jnp.broadcast_to(h[:, None], (b, num_rows, self.hidden))], axis=-1)
        return RawNetworkOutput(
            *as_float32((
                nn.Dense(1, dtype=self.dtype, name="value")(h)[:, 0],
                nn.Dense(self.spec.num_functions, dtype=self.dtype, name="function")(h),
                pixel_logits(nn.Conv(1, (1, 1), dtype=self.dtype, name="world")(state)),
                nn.Dense(2, dtype=self.dtype, name="queued")(h),
                nn.Dense(1, dtype=self.dtype, name="unit_logits")(per_row)[..., 0],
                nn.Dense(1, dtype=self.dtype, name="target_logits")(per_row)[..., 0])),
            own, real)
