"""What every network returns: value, function logits and argument logits.

The argument logits follow the dense action layout (`DenseAction`, `TYPES` order).
A scalar argument's logits are an array [B..., n]. A point argument's logits are
either

- `PixelLogits` (FullyConv, FullyConv LSTM, arFullyConv): one softmax over all
  pixels, flattened row-major from (y, x): pixel index `y * width + x`, [B..., H*W]; or
- `XYLogits` (Atari-net): independent logits over x [B..., X] and over y [B..., Y].

`sc2jax.networks.policy` turns either form into a distribution.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
from flax import struct

from sc2jax.environment.interface.arguments import Arguments


@struct.dataclass
class PixelLogits:
    """Logits over all pixels of a point argument.

    Attributes:
      logits: [B..., H*W], pixel index `y * width + x`.
      width: the x resolution (static).
    """

    logits: jax.Array
    width: int = struct.field(pytree_node=False)

    @property
    def height(self) -> int:
        return self.logits.shape[-1] // self.width

    def to_xy(self, index: jax.Array) -> jax.Array:
        """Pixel indices [B...] to points [B..., 2] as (x, y), int32."""
        index = index.astype(jnp.int32)
        return jnp.stack([index % self.width, index // self.width], axis=-1)

    def to_index(self, point: jax.Array) -> jax.Array:
        """Points [B..., 2] as (x, y) to pixel indices [B...], int32."""
        point = point.astype(jnp.int32)
        return point[..., 1] * self.width + point[..., 0]


class XYLogits(NamedTuple):
    """Independent logits over the x and the y of a point argument.

    Attributes:
      x: [B..., X].
      y: [B..., Y].
    """

    x: jax.Array
    y: jax.Array


class ArgumentLogits(NamedTuple):
    """Logits of the 13 argument types, in `TYPES` order (fields as `DenseAction`)."""

    screen: Any
    minimap: Any
    screen2: Any
    queued: Any
    control_group_act: Any
    control_group_id: Any
    select_point_act: Any
    select_add: Any
    select_unit_act: Any
    select_unit_id: Any
    select_worker: Any
    build_queue_id: Any
    unload_id: Any


assert ArgumentLogits._fields == Arguments._fields


class NetworkOutput(NamedTuple):
    """The output of every network.

    Attributes:
      value: [B...] the state value v(s) (a logit of P(win) under the supervised loss).
      function_logits: [B..., num_functions] unmasked logits of the function id.
      argument_logits: `ArgumentLogits`, see the module docstring.
    """

    value: jax.Array
    function_logits: jax.Array
    argument_logits: ArgumentLogits


def as_float32(out):
    """`out` (a `NetworkOutput`, logits, any tree of arrays) with every array float32: a
    network computing in bfloat16 returns float32 values and logits, for the policy's
    log-softmax and the losses."""
    return jax.tree.map(lambda x: x.astype(jnp.float32), out)


class LSTMCarry(NamedTuple):
    """The ConvLSTM state, each [B, Ys, Xs, features] at the screen resolution."""

    c: jax.Array
    h: jax.Array
