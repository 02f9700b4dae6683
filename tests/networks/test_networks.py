"""The contract every network meets, and the paper's layer sizes."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import ObservationFormat
from sc2jax.networks import NetworkOutput, PixelLogits, XYLogits, make_network
from tests.networks.helpers import BATCH, fast_init, jitted_apply, network, random_obs, seq_obs


def _output(name, obs):
    net, params = network(name)
    if name == "fullyconv_lstm":
        t = 1
        carry, out = jitted_apply(name)(params, net.initial_carry(BATCH),
                                        jax.tree.map(lambda x: x[None], obs),
                                        jnp.zeros((t, BATCH), bool))
        return jax.tree.map(lambda x: x[0], out)
    return jitted_apply(name)(params, obs)


@pytest.mark.parametrize("name", ["atari", "fullyconv", "fullyconv_lstm", "arfullyconv"])
def test_output_contract(name):
    out = _output(name, random_obs(1))
    assert isinstance(out, NetworkOutput)
    assert out.value.shape == (BATCH,) and out.function_logits.shape == (BATCH, 573)
    sizes = [(2,), (5,), (10,), (4,), (2,), (4,), (500,), (4,), (10,), (500,)]
    for logits, (n,) in zip(out.argument_logits[3:], sizes):
        assert logits.shape == (BATCH, n)
    for logits in out.argument_logits[:3]:
        if name == "atari":  # independent x and y logits
            assert isinstance(logits, XYLogits)
            assert logits.x.shape == (BATCH, 16) and logits.y.shape == (BATCH, 16)
        else:  # one softmax over the 16 * 16 pixels
            assert isinstance(logits, PixelLogits) and logits.logits.shape == (BATCH, 256)
            assert logits.width == 16
    assert all(np.isfinite(x).all() for x in jax.tree.leaves(out))


def test_atari_net_layer_sizes():
    p = network("atari")[1]["params"]
    # 14 input channels (player_relative 2 + unit_type 11 + unit_hit_points 1).
    assert p["screen_conv"]["conv1"]["kernel"].shape == (8, 8, 14, 16)
    assert p["screen_conv"]["conv2"]["kernel"].shape == (4, 4, 16, 32)
    # 16x16 -> stride 4 -> 4x4 -> stride 2 -> 2x2; 2 * (2*2*32) + 64 non-spatial = 320.
    assert p["fc"]["kernel"].shape == (320, 256)
    assert p["point_heads"]["arg_1_x"]["kernel"].shape == (256, 16)


def test_fully_conv_layer_sizes():
    p = network("fullyconv")[1]["params"]
    assert p["torso"]["screen_conv"]["conv1"]["kernel"].shape == (5, 5, 14, 16)
    assert p["torso"]["screen_conv"]["conv2"]["kernel"].shape == (3, 3, 16, 32)
    # minimap: player_relative 2 + camera 1 channels.
    assert p["torso"]["minimap_conv"]["conv1"]["kernel"].shape == (5, 5, 3, 16)
    # state: 32 screen + 32 minimap + 11 broadcast player features = 75 channels.
    assert p["heads"]["point_heads"]["arg_0"]["kernel"].shape == (1, 1, 75, 1)
    assert p["heads"]["fc"]["kernel"].shape == (16 * 16 * 75, 256)


def test_screen_and_minimap_resolutions_may_differ():
    fmt = ObservationFormat(screen_size=16, minimap_size=(24, 20),
                            screen_features=("player_relative",),
                            minimap_features=("player_relative",))
    obs = random_obs(3, fmt=fmt)
    net = make_network("fullyconv", fmt, hidden=8)
    out = jax.jit(net.apply)(fast_init(net, obs), obs)
    screen, minimap = out.argument_logits.screen, out.argument_logits.minimap
    # The state is at the screen resolution; the minimap head at the minimap resolution.
    assert screen.logits.shape == (BATCH, 16 * 16)
    assert minimap.logits.shape == (BATCH, 24 * 20) and minimap.width == 24


def test_lstm_rejects_mismatched_time_dims():
    net, params = network("fullyconv_lstm")
    with pytest.raises(ValueError, match=r"first has shape \(2,\); expected \[T, B\]"):
        net.apply(params, net.initial_carry(BATCH), seq_obs(0, 2), jnp.zeros((2,), bool))
