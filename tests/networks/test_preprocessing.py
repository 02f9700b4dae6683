"""Input pre-processing: embeddings equal one-hot + 1x1 conv; log rescaling."""

import jax
import jax.numpy as jnp
import numpy as np
from flax.linen.linear import default_embed_init

from sc2jax.environment import SCREEN_FEATURES
from sc2jax.networks import SpatialEncoder, embedding_dim, log_transform
from sc2jax.networks.fully_conv import FullyConvStack
from sc2jax.networks.preprocessing import background_zero_init, nonspatial_features
from tests.networks.helpers import SPEC, fast_init, random_obs


def test_embedding_dims():
    # round(log2(scale)), at least 1: 2 -> 1, 5 -> round(2.32) = 2, 1962 -> round(10.94) = 11.
    assert [embedding_dim(s) for s in (2, 4, 5, 17, 290, 1962)] == [1, 2, 2, 4, 8, 11]


def test_log_transform_hand_values():
    # log(1 + x): 0 -> 0, e - 1 -> 1, negative values clip to 0.
    x = jnp.array([0.0, np.e - 1, -5.0])
    np.testing.assert_allclose(log_transform(x), [0.0, 1.0, 0.0], atol=1e-6)


def test_categorical_embedding_is_one_hot_times_1x1_conv():
    layers = (SCREEN_FEATURES.player_relative, SCREEN_FEATURES.unit_type,
              SCREEN_FEATURES.unit_hit_points)
    enc = SpatialEncoder(layers)
    x = random_obs(3)["feature_screen"]  # [2, 3, 16, 16]
    params = fast_init(enc, x)
    out = enc.apply(params, x)
    # player_relative -> 2 channels, unit_type -> 11, unit_hit_points -> 1 (log1p).
    assert enc.out_channels == 14 and out.shape == (2, 16, 16, 14)
    for c, (name, lo, hi) in enumerate([("player_relative", 0, 2), ("unit_type", 2, 13)]):
        table = params["params"][f"embed_{name}"]["embedding"]  # the 1x1 conv's weights
        one_hot = jax.nn.one_hot(x[:, c], layers[c].scale)  # [2, 16, 16, scale]
        np.testing.assert_allclose(out[..., lo:hi], one_hot @ table, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(out[..., 13], np.log1p(np.asarray(x[:, 2], np.float32)),
                               rtol=1e-6)


def test_nonspatial_features_are_log_scaled():
    obs = random_obs(4)
    out = nonspatial_features(SPEC, obs)
    assert out.shape == (2, 11)
    np.testing.assert_allclose(out, np.log1p(np.asarray(obs["player"], np.float32)), rtol=1e-6)


def test_background_category_starts_at_zero():
    key = jax.random.key(5)
    table = background_zero_init(key, (5, 2))
    default = default_embed_init(key, (5, 2))
    np.testing.assert_array_equal(table[0], 0.0)
    np.testing.assert_array_equal(table[1:], default[1:])  # Flax's draw for the others


def test_an_empty_screen_has_no_border_at_initialisation():
    # All background (category 0): the embedded screen is zero, as the convolutions' zero
    # padding is, so FullyConv's stack gives every pixel the same output. With Flax's
    # default table (row 0 not zero) the outer 3 pixels differ from the interior.
    layers = (SCREEN_FEATURES.player_relative, SCREEN_FEATURES.selected)
    enc, stack = SpatialEncoder(layers), FullyConvStack()
    empty = jnp.zeros((1, 2, 16, 16), jnp.int32)
    enc_params = enc.init(jax.random.key(0), empty)
    embedded = enc.apply(enc_params, empty)
    stack_params = stack.init(jax.random.key(1), embedded)
    out = np.asarray(stack.apply(stack_params, embedded))
    np.testing.assert_array_equal(out, 0.0)
    shifted = jax.tree.map(lambda t: t + 1.0, enc_params)  # a non-zero background
    border = np.asarray(stack.apply(stack_params, enc.apply(shifted, empty)))[0]
    interior = border[3:-3, 3:-3]
    assert np.ptp(interior, axis=(0, 1)).max() < 1e-5  # uniform inside
    assert np.abs(border[0, 0] - interior[0, 0]).max() > 1e-3  # the corner differs
