"""Atari-net (paper §4.3, "Atari-net Agent").

Screen and minimap each: conv 16 filters 8x8 stride 4, ReLU; conv 32 filters 4x4
stride 2, ReLU (the A3C network of Mnih et al. 2016). Non-spatial features: a linear
layer with tanh. The three are concatenated and passed through a linear layer of 256
units with ReLU. Linear heads give the value, the function-id logits, the logits of
each non-spatial argument, and independent x and y logits for each point argument.

Choices the paper leaves open: convolutions use SAME padding, so every resolution
from 16 up works (64 -> 16 -> 8; 16 -> 4 -> 2); the non-spatial linear layer has
`nonspatial_features` (64) units.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.networks.heads import ScalarArgumentHeads, XYHeads
from sc2jax.networks.outputs import ArgumentLogits, NetworkOutput, as_float32
from sc2jax.networks.preprocessing import SpatialEncoder, nonspatial_features, spatial_inputs
from sc2jax.networks.spec import NetworkSpec


class AtariConvStack(nn.Module):
    """Conv 16x8x8/4 -> ReLU -> conv 32x4x4/2 -> ReLU -> flatten: [B, H, W, C] -> [B, D]."""

    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        x = nn.relu(nn.Conv(16, (8, 8), strides=(4, 4), padding="SAME",
                            dtype=self.dtype, name="conv1")(x))
        x = nn.relu(nn.Conv(32, (4, 4), strides=(2, 2), padding="SAME",
                            dtype=self.dtype, name="conv2")(x))
        return x.reshape(x.shape[0], -1)


class AtariNet(nn.Module):
    """The Atari-net baseline.

    Attributes:
      spec: input and output sizes (`NetworkSpec.from_format(fmt)`).
      nonspatial_features: units of the tanh layer on the non-spatial features.
      hidden: units of the ReLU layer after the concatenation (256 in the paper).
      dtype: the computation dtype of every layer (the parameters and outputs stay
        float32).
    """

    spec: NetworkSpec
    nonspatial_features: int = 64
    hidden: int = 256
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, obs: Mapping[str, jax.Array],
                 action: DenseAction | None = None) -> NetworkOutput:
        """Runs the network on a batch of padded observations.

        Args:
          obs: padded observations with a batch dim: feature_screen [B, Cs, Ys, Xs],
            feature_minimap [B, Cm, Ym, Xm], and the non-spatial keys of the spec.
          action: ignored (the policy is not autoregressive); accepted so that every
            feed-forward network has the same call signature.

        Returns:
          `NetworkOutput`: value [B], function_logits [B, 573], argument logits with
          `XYLogits` ([B, X], [B, Y]) for point types and [B, n] for scalar types.
        """
        del action
        screen, minimap = spatial_inputs(self.spec, obs)
        s = AtariConvStack(self.dtype, name="screen_conv")(
            SpatialEncoder(self.spec.screen_layers, "feature_screen", self.dtype,
                           name="screen_embed")(screen))
        m = AtariConvStack(self.dtype, name="minimap_conv")(
            SpatialEncoder(self.spec.minimap_layers, "feature_minimap", self.dtype,
                           name="minimap_embed")(minimap))
        ns = jnp.tanh(nn.Dense(self.nonspatial_features, dtype=self.dtype, name="nonspatial")(
            nonspatial_features(self.spec, obs)))
        h = nn.relu(nn.Dense(self.hidden, dtype=self.dtype, name="fc")(
            jnp.concatenate([s, m, ns], axis=-1)))
        args = {**ScalarArgumentHeads(self.spec, self.dtype, name="scalar_heads")(h),
                **XYHeads(self.spec, self.dtype, name="point_heads")(h)}
        return as_float32(NetworkOutput(
            value=nn.Dense(1, dtype=self.dtype, name="value")(h)[:, 0],
            function_logits=nn.Dense(self.spec.num_functions, dtype=self.dtype, name="function")(h),
            argument_logits=ArgumentLogits(*(args[i] for i in range(len(args))))))
