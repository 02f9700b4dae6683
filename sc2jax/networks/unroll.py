"""Any of the four networks over time-major inputs: the one place that knows how each
network runs over a trajectory (FullyConv LSTM carries its state through time,
arFullyConv takes the actions for teacher forcing), so that losses need not."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.networks.ar_fully_conv import ARFullyConv
from sc2jax.networks.fully_conv_lstm import FullyConvLSTM
from sc2jax.networks.outputs import LSTMCarry, NetworkOutput


def unroll(network: nn.Module, params: Any, observation: Mapping[str, jax.Array],
           action: DenseAction | None = None, first: jax.Array | None = None,
           initial_carry: LSTMCarry | None = None) -> NetworkOutput:
    """Runs any network over time-major inputs [N, B, ...].

    Args:
      network: one of the four networks.
      params: its parameters.
      observation: leaves [N, B, ...].
      action: `DenseAction` [N, B] for arFullyConv's teacher forcing (None: no_op).
      first: [N, B] episode starts (FullyConv LSTM).
      initial_carry: FullyConv LSTM carry before the first step.

    Returns:
      `NetworkOutput` with leading dims [N, B].
    """
    n, b = jnp.shape(observation["available_actions_mask"])[:2]
    if isinstance(network, FullyConvLSTM):
        if first is None or initial_carry is None:
            raise ValueError("FullyConvLSTM needs `first` and `initial_carry`")
        return network.apply(params, initial_carry, observation, first)[1]
    flat = jax.tree.map(lambda x: jnp.reshape(x, (n * b,) + jnp.shape(x)[2:]), dict(observation))
    if isinstance(network, ARFullyConv) and action is not None:
        action = jax.tree.map(lambda x: jnp.reshape(x, (n * b,) + jnp.shape(x)[2:]), action)
        out = network.apply(params, flat, action)
    else:
        out = network.apply(params, flat)
    return jax.tree.map(lambda x: jnp.reshape(x, (n, b) + x.shape[1:]), out)
