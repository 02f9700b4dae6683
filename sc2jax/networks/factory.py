"""Builds a network by name from the environment's observation format, and acts."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import flax.linen as nn
import jax
import jax.numpy as jnp

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.raw import RawAction
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.networks.ar_fully_conv import ARFullyConv
from sc2jax.networks.atari_net import AtariNet
from sc2jax.networks.fully_conv import FullyConv
from sc2jax.networks.fully_conv_lstm import FullyConvLSTM
from sc2jax.networks.outputs import NetworkOutput
from sc2jax.networks.raw_fully_conv import RawFullyConv
from sc2jax.networks.raw_policy import RawNetworkOutput, policy_of
from sc2jax.networks.spec import DEFAULT_NONSPATIAL_KEYS, NetworkSpec

NETWORKS: dict[str, type[nn.Module]] = {
    "atari": AtariNet,
    "fullyconv": FullyConv,
    "fullyconv_lstm": FullyConvLSTM,
    "arfullyconv": ARFullyConv,
    "raw_fullyconv": RawFullyConv,
}
"""The networks by name."""

RAW_NETWORKS = ("raw_fullyconv",)
"""The networks of the raw interface (`action_space="raw"`); the others take the
feature interface's actions."""

COMPUTE_DTYPES = ("float32", "bfloat16")
"""The dtypes a network may compute its layers in (`make_network(dtype=)`); parameters
and outputs are float32 in both."""


def make_network(name: str, fmt: ObservationFormat | NetworkSpec, *,
                 nonspatial_keys: Sequence[str] = DEFAULT_NONSPATIAL_KEYS,
                 dtype: str = "float32", **kwargs: Any) -> nn.Module:
    """Builds a network, its sizes taken from the environment's specs.

    Args:
      name: one of "atari", "fullyconv", "fullyconv_lstm", "arfullyconv" (formats of the
        feature action space), or "raw_fullyconv" (of the raw one, with a
        raw_resolution).
      fmt: the environment's `ObservationFormat` (`env.simulator.fmt`), from which the
        padded observation spec and the action spec are derived; or a `NetworkSpec`.
      nonspatial_keys: observation keys for the non-spatial input (ignored for a
        `NetworkSpec`).
      dtype: the dtype its convolutions and matmuls compute in (`COMPUTE_DTYPES`).
      **kwargs: the network's own attributes (e.g. `hidden=256`, `lstm_features=32`).

    Returns:
      An unbound Flax module.

    Raises:
      ValueError: for an unknown name or dtype (the message lists the allowed ones), or
        a network of the other action space than the format's.
      TypeError: if `fmt` is neither an `ObservationFormat` nor a `NetworkSpec`.
    """
    if name not in NETWORKS:
        raise ValueError(f"unknown network {name!r}; allowed: {sorted(NETWORKS)}")
    if dtype not in COMPUTE_DTYPES:
        raise ValueError(f"unknown compute dtype {dtype!r}; allowed: {list(COMPUTE_DTYPES)}")
    if isinstance(fmt, NetworkSpec):
        spec = fmt
    elif isinstance(fmt, ObservationFormat):
        spec = NetworkSpec.from_format(fmt, nonspatial_keys)
    else:
        raise TypeError(f"fmt must be an ObservationFormat or a NetworkSpec, "
                        f"got {type(fmt).__name__}")
    if (spec.action_space == "raw") != (name in RAW_NETWORKS):
        allowed = RAW_NETWORKS if spec.action_space == "raw" else sorted(
            set(NETWORKS) - set(RAW_NETWORKS))
        raise ValueError(f"network {name!r} does not take the {spec.action_space!r} action "
                         f"space; networks that do: {list(allowed)}")
    return NETWORKS[name](spec, dtype=jnp.dtype(dtype), **kwargs)


def act(network: nn.Module, params: Any, key: jax.Array | None, obs: Mapping[str, jax.Array],
        temperature: float | jax.Array = 1.0
        ) -> tuple[DenseAction | RawAction, NetworkOutput | RawNetworkOutput]:
    """Samples actions from a feed-forward network (greedy if `key` is None).

    Args:
      network: an `AtariNet`, `FullyConv`, `ARFullyConv` or `RawFullyConv`.
      params: its parameters.
      key: a PRNG key or None.
      obs: padded observations [B, ...] with available_actions_mask [B, F].
      temperature: softmax temperature (> 0).

    Returns:
      (DenseAction of int32 [B...], or a RawAction for a raw network; the output the
      action was drawn from).

    Raises:
      TypeError: for a recurrent network (use `FullyConvLSTM.step` and `policy.sample`).
    """
    if isinstance(network, FullyConvLSTM):
        raise TypeError("act takes a feed-forward network; for FullyConvLSTM call "
                        "network.apply(params, carry, obs, first, method='step') then "
                        "policy.sample")
    if isinstance(network, ARFullyConv):
        return network.apply(params, obs, key, temperature, method="sample")
    out = network.apply(params, obs)
    return policy_of(out).sample(key, out, obs["available_actions_mask"], temperature), out
