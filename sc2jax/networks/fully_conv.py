"""FullyConv (paper §4.3, "FullyConv Agent").

Screen and minimap each: conv 16 filters 5x5, ReLU; conv 32 filters 3x3, ReLU; SAME
padding and no stride, so the resolution is preserved. The state representation is
the channel concatenation of the screen output, the minimap output and the broadcast
(log-rescaled) non-spatial features. The value, the function id and the non-spatial
arguments come from a fully-connected layer of 256 units with ReLU on the (flattened)
state, followed by linear layers. Each point argument gets a 1x1 convolution of the
state with one output channel, and a softmax over all pixels.

Different screen and minimap resolutions: the minimap output is resized (bilinear)
to the screen resolution before the concatenation, and the minimap argument head
resizes the state back to the minimap resolution (see `heads`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.networks.heads import ConvPointHeads, ScalarArgumentHeads, broadcast_vector, resize
from sc2jax.networks.outputs import ArgumentLogits, NetworkOutput, as_float32
from sc2jax.networks.preprocessing import SpatialEncoder, nonspatial_features, spatial_inputs
from sc2jax.networks.spec import NetworkSpec


class FullyConvStack(nn.Module):
    """Conv 16x5x5 -> ReLU -> conv 32x3x3 -> ReLU, SAME padding, stride 1."""

    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        """Args: x: [B, H, W, C]. Returns: [B, H, W, 32]."""
        x = nn.relu(nn.Conv(16, (5, 5), padding="SAME", dtype=self.dtype, name="conv1")(x))
        return nn.relu(nn.Conv(32, (3, 3), padding="SAME", dtype=self.dtype, name="conv2")(x))


class FullyConvTorso(nn.Module):
    """The state representation of FullyConv: [B, Ys, Xs, 32 + 32 + D_nonspatial]."""

    spec: NetworkSpec
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, obs: Mapping[str, jax.Array]) -> jax.Array:
        """Args: obs: padded observations with a batch dim (see `FullyConv`).

        Returns: [B, Ys, Xs, C] at the screen resolution.
        """
        screen, minimap = spatial_inputs(self.spec, obs)
        s = FullyConvStack(self.dtype, name="screen_conv")(
            SpatialEncoder(self.spec.screen_layers, "feature_screen", self.dtype,
                           name="screen_embed")(screen))
        m = FullyConvStack(self.dtype, name="minimap_conv")(
            SpatialEncoder(self.spec.minimap_layers, "feature_minimap", self.dtype,
                           name="minimap_embed")(minimap))
        m = resize(m, self.spec.screen_size)
        ns = broadcast_vector(nonspatial_features(self.spec, obs).astype(self.dtype),
                              s.shape[1], s.shape[2])
        return jnp.concatenate([s, m, ns], axis=-1)


class FullyConvHeads(nn.Module):
    """Value, function, scalar-argument and point-argument heads on a spatial state."""

    spec: NetworkSpec
    hidden: int = 256
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, state: jax.Array) -> NetworkOutput:
        """Args: state: [B, Ys, Xs, C]. Returns: `NetworkOutput` with `PixelLogits`."""
        h = nn.relu(nn.Dense(self.hidden, dtype=self.dtype, name="fc")(
            state.reshape(state.shape[0], -1)))
        args = {**ScalarArgumentHeads(self.spec, self.dtype, name="scalar_heads")(h),
                **ConvPointHeads(self.spec, self.dtype, name="point_heads")(state)}
        return as_float32(NetworkOutput(
            value=nn.Dense(1, dtype=self.dtype, name="value")(h)[:, 0],
            function_logits=nn.Dense(self.spec.num_functions, dtype=self.dtype, name="function")(h),
            argument_logits=ArgumentLogits(*(args[i] for i in range(len(args))))))


class FullyConv(nn.Module):
    """The FullyConv baseline.

    Attributes:
      spec: input and output sizes (`NetworkSpec.from_format(fmt)`).
      hidden: units of the fully-connected layer (256 in the paper).
      dtype: the computation dtype of every layer (`COMPUTE_DTYPES`; the parameters
        and outputs stay float32).
    """

    spec: NetworkSpec
    hidden: int = 256
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, obs: Mapping[str, jax.Array],
                 action: DenseAction | None = None) -> NetworkOutput:
        """Runs the network on a batch of padded observations.

        Args:
          obs: padded observations with a batch dim: feature_screen [B, Cs, Ys, Xs],
            feature_minimap [B, Cm, Ym, Xm], and the non-spatial keys of the spec.
          action: ignored (independent policy heads).

        Returns:
          `NetworkOutput`: value [B], function_logits [B, 573], `PixelLogits` [B, X*Y]
          for point types (minimap at the minimap resolution), [B, n] for scalar types.
        """
        del action
        state = FullyConvTorso(self.spec, self.dtype, name="torso")(obs)
        return FullyConvHeads(self.spec, self.hidden, self.dtype, name="heads")(state)
