"""sc2jax.networks: the paper's baseline agents' networks and the policy distribution.

Atari-net, FullyConv, FullyConv LSTM and arFullyConv (Vinyals et al. 2017, §4.3 and
§5.2), and Raw FullyConv on PySC2's raw interface, built from the environment's specs;
see docs/networks.md.
"""

from sc2jax.networks import policy, raw_policy
from sc2jax.networks.ar_fully_conv import ARFullyConv
from sc2jax.networks.atari_net import AtariNet
from sc2jax.networks.factory import NETWORKS, RAW_NETWORKS, act, make_network
from sc2jax.networks.fully_conv import FullyConv, FullyConvTorso
from sc2jax.networks.fully_conv_lstm import FullyConvLSTM
from sc2jax.networks.outputs import (
    ArgumentLogits,
    LSTMCarry,
    NetworkOutput,
    PixelLogits,
    XYLogits,
)
from sc2jax.networks.policy import (
    MASKED_LOGIT,
    PolicyEntropy,
    PolicyLogProb,
    entropy,
    log_prob,
    mask_function_logits,
    mode,
    sample,
    used_arguments,
)
from sc2jax.networks.preprocessing import SpatialEncoder, embedding_dim, log_transform
from sc2jax.networks.raw_fully_conv import RawFullyConv
from sc2jax.networks.raw_policy import RawNetworkOutput
from sc2jax.networks.spec import DEFAULT_NONSPATIAL_KEYS, NetworkSpec
from sc2jax.networks.unroll import unroll

__all__ = [name for name in dir() if not name.startswith("_")]
