"""FullyConv LSTM (paper §4.3, "FullyConv LSTM Agent").

The FullyConv pipeline with a convolutional LSTM after the concatenation of the
screen, minimap and broadcast non-spatial features: the ConvLSTM's output replaces
the state representation fed to the heads. The network unrolls over [T, B] sequences
(`__call__`) or acts one step at a time (`step`). At every step where `first` is
True (the first observation of an episode), the carry is zeroed before the ConvLSTM
update, as purejaxrl's `ppo_rnn` resets its LSTM on `done`.

The convolutional torso and the heads run on all T*B observations at once; only the
ConvLSTM cell runs inside the `scan` over time.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.networks.fully_conv import FullyConvHeads, FullyConvTorso
from sc2jax.networks.outputs import LSTMCarry, NetworkOutput
from sc2jax.networks.spec import NetworkSpec


class ResettingConvLSTM(nn.Module):
    """One ConvLSTM step that first zeroes the carry where `first` is True."""

    features: int
    kernel_size: int
    dtype: Any = jnp.float32

    @nn.compact
    def __call__(self, carry: LSTMCarry, inputs: tuple[jax.Array, jax.Array]
                 ) -> tuple[LSTMCarry, jax.Array]:
        """Args: carry: `LSTMCarry`; inputs: (x [B, H, W, C], first [B] bool).

        Returns: (new carry, output h [B, H, W, features]).
        """
        x, first = inputs
        keep = jnp.logical_not(first.astype(bool))[:, None, None, None]
        carry = (jnp.where(keep, carry.c, 0.0), jnp.where(keep, carry.h, 0.0))
        (c, h), out = nn.ConvLSTMCell(
            self.features, (self.kernel_size, self.kernel_size), dtype=self.dtype,
            name="cell")(carry, x)
        # The carry stays float32 from step to step, whatever the computation's dtype.
        return LSTMCarry(c.astype(jnp.float32), h.astype(jnp.float32)), out


class FullyConvLSTM(nn.Module):
    """The FullyConv LSTM baseline.

    Attributes:
      spec: input and output sizes (`NetworkSpec.from_format(fmt)`).
      lstm_features: ConvLSTM channels (not given in the paper).
      kernel_size: ConvLSTM kernel size (square, SAME padding).
      hidden: units of the fully-connected layer (256 in the paper).
      dtype: the computation dtype of every layer (the parameters, the carry and the
        outputs stay float32).
    """

    spec: NetworkSpec
    lstm_features: int = 32
    kernel_size: int = 3
    hidden: int = 256
    dtype: Any = jnp.float32

    def initial_carry(self, batch_size: int) -> LSTMCarry:
        """All-zero carry for `batch_size` environments (no parameters needed)."""
        width, height = self.spec.screen_size
        zeros = jnp.zeros((batch_size, height, width, self.lstm_features), jnp.float32)
        return LSTMCarry(zeros, zeros)

    @nn.compact
    def __call__(self, carry: LSTMCarry, obs: Mapping[str, jax.Array],
                 first: jax.Array) -> tuple[LSTMCarry, NetworkOutput]:
        """Unrolls over a sequence.

        Args:
          carry: `LSTMCarry` before the first step, each [B, Ys, Xs, lstm_features].
          obs: padded observations with leading dims [T, B] (e.g. feature_screen
            [T, B, Cs, Ys, Xs]).
          first: [T, B] bool, True at the first observation of an episode; the carry
            is zeroed before that step.

        Returns:
          (carry after the last step, `NetworkOutput` with leading dims [T, B]).
        """
        first = jnp.asarray(first)
        if first.ndim != 2:
            raise ValueError(f"first has shape {first.shape}; expected [T, B]")
        t, b = first.shape
        for key, value in obs.items():
            if tuple(jnp.shape(value)[:2]) != (t, b):
                raise ValueError(f"observation[{key!r}] has shape {jnp.shape(value)}; expected "
                                 f"leading dims [T, B] = [{t}, {b}] like `first`")
        flat = {k: jnp.reshape(v, (t * b,) + jnp.shape(v)[2:]) for k, v in obs.items()}
        state = FullyConvTorso(self.spec, self.dtype, name="torso")(flat)
        state = state.reshape((t, b) + state.shape[1:])
        # Fully unrolled: XLA's CPU backend runs convolutions (and their gradients) inside
        # a while loop about 40x slower than unrolled, and compiles them slower too.
        scan = nn.scan(ResettingConvLSTM, variable_broadcast="params",
                       split_rngs={"params": False}, in_axes=0, out_axes=0, unroll=True)
        carry, h = scan(self.lstm_features, self.kernel_size, self.dtype, name="conv_lstm")(
            carry, (state, first))
        out = FullyConvHeads(self.spec, self.hidden, self.dtype, name="heads")(
            h.reshape((t * b,) + h.shape[2:]))
        return carry, jax.tree.map(lambda x: x.reshape((t, b) + x.shape[1:]), out)

    def step(self, carry: LSTMCarry, obs: Mapping[str, jax.Array],
             first: jax.Array) -> tuple[LSTMCarry, NetworkOutput]:
        """One acting step: obs leaves [B, ...], first [B]; returns outputs [B...]."""
        carry, out = self(carry, jax.tree.map(lambda x: jnp.asarray(x)[None], dict(obs)),
                          jnp.asarray(first)[None])
        return carry, jax.tree.map(lambda x: x[0], out)
