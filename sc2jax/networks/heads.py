"""Output heads shared by the networks, and spatial resizing.

Screen and minimap may have different resolutions. The fully-convolutional networks
build their state representation at the screen resolution: the minimap branch's
output is resized (bilinear) to the screen resolution before the concatenation, and
the minimap argument head resizes the state representation back to the minimap
resolution before its 1x1 convolution, so minimap logits are over minimap pixels.
When the resolutions are equal, no resizing happens.
"""

from __future__ import annotations

from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.networks.outputs import PixelLogits, XYLogits
from sc2jax.networks.spec import NetworkSpec


def resize(x: jax.Array, size: tuple[int, int]) -> jax.Array:
    """Resizes [B, H, W, C] to [B, size[1], size[0], C] (bilinear); no-op when equal.

    Args:
      x: [B, H, W, C].
      size: the target (x, y) = (W, H).
    """
    width, height = size
    if x.shape[1:3] == (height, width):
        return x
    return jax.image.resize(x, (x.shape[0], height, width, x.shape[3]), method="linear")


def broadcast_vector(v: jax.Array, height: int, width: int) -> jax.Array:
    """Tiles [B, D] over space: [B, height, width, D]."""
    return jnp.broadcast_to(v[:, None, None, :], (v.shape[0], height, width, v.shape[-1]))


class ScalarArgumentHeads(nn.Module):
    """Linear heads for the non-spatial arguments: {type id: logits [B, n]}."""

    spec: NetworkSpec
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, h: jax.Array) -> dict[int, jax.Array]:
        """Args: h: [B, D]. Returns: {argument type id: [B, n]} for scalar types."""
        return {i: nn.Dense(sizes[0], dtype=self.dtype, name=f"arg_{i}")(h)
                for i, sizes in enumerate(self.spec.argument_sizes) if len(sizes) == 1}


class XYHeads(nn.Module):
    """Atari-net's spatial heads: independent linear x and y logits per point type."""

    spec: NetworkSpec
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, h: jax.Array) -> dict[int, XYLogits]:
        """Args: h: [B, D]. Returns: {point type id: XYLogits([B, X], [B, Y])}."""
        return {i: XYLogits(nn.Dense(sizes[0], dtype=self.dtype, name=f"arg_{i}_x")(h),
                            nn.Dense(sizes[1], dtype=self.dtype, name=f"arg_{i}_y")(h))
                for i, sizes in enumerate(self.spec.argument_sizes) if len(sizes) == 2}


def pixel_logits(logit_map: jax.Array) -> PixelLogits:
    """[B, H, W, 1] logits to `PixelLogits` [B, H*W] (row-major over (y, x))."""
    b, h, w, _ = logit_map.shape
    return PixelLogits(logit_map.reshape(b, h * w), width=w)


class ConvPointHeads(nn.Module):
    """FullyConv's spatial heads: a 1x1 convolution with one output channel per point
    type, then a softmax over all pixels (applied by the policy utility).

    The state is at the screen resolution; each head works at its type's resolution
    (the state is resized for the minimap head).
    """

    spec: NetworkSpec
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, state: jax.Array) -> dict[int, PixelLogits]:
        """Args: state: [B, H, W, C] at the screen resolution.

        Returns: {point type id: PixelLogits [B, X*Y]}.
        """
        out = {}
        for i in self.spec.point_argument_ids:
            x = resize(state, self.spec.argument_sizes[i])
            out[i] = pixel_logits(nn.Conv(1, (1, 1), dtype=self.dtype, name=f"arg_{i}")(x))
        return out
