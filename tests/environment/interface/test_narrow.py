"""Feature layers packed into bytes: exact, a quarter to 0.29 of int32's bytes, and read
by the networks as the int32 layers are."""

import jax
import numpy as np
import pytest

from sc2jax.environment.interface import narrow
from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES
from tests.networks.helpers import FMT, jitted_apply, network, random_obs


def test_the_wide_layers_are_those_above_a_byte():
    assert [SCREEN_FEATURES[c].name for c in narrow.wide_channels(SCREEN_FEATURES)] == [
        "unit_type", "unit_hit_points", "unit_energy", "unit_shields", "buffs"]
    assert [MINIMAP_FEATURES[c].name for c in narrow.wide_channels(MINIMAP_FEATURES)] == [
        "unit_type"]


@pytest.mark.parametrize("features", [SCREEN_FEATURES, MINIMAP_FEATURES])
def test_pack_is_exact_over_the_whole_range(features):
    rng = np.random.default_rng(0)
    c = len(features)
    scales = np.array([f.scale for f in features]).reshape(c, 1, 1)
    layers = (rng.random((3, c, 8, 8)) * scales).astype(np.int32)
    layers[0, narrow.wide_channels(features)] = 2 ** 16 - 1  # the top of the range
    low, high = narrow.pack(layers, features)
    assert low.dtype == high.dtype == np.uint8
    assert high.shape == (3, len(narrow.wide_channels(features)), 8, 8)
    np.testing.assert_array_equal(narrow.unpack(low, high, features), layers)


def test_bytes_per_position():
    """All 38 layers: 44 bytes a position against int32's 152 (0.29); narrow ones: 1/4."""
    def nbytes(features):
        low, high = narrow.pack(np.zeros((len(features), 4, 4), np.int32), features)
        return (low.nbytes + high.nbytes) / 16
    assert nbytes(SCREEN_FEATURES) + nbytes(MINIMAP_FEATURES) == 44
    narrow_only = [f for f in SCREEN_FEATURES if f.scale <= narrow.BYTE_SCALE]
    assert nbytes(narrow_only) == len(narrow_only)


def test_unpack_refuses_high_bytes_of_other_layers():
    low, high = narrow.pack(np.zeros((len(SCREEN_FEATURES), 4, 4), np.int32), SCREEN_FEATURES)
    with pytest.raises(ValueError, match="5 wide ones"):
        narrow.unpack(low, high[:2], SCREEN_FEATURES)


@pytest.mark.parametrize("name", ["atari", "fullyconv"])
def test_a_network_reads_a_packed_observation_as_the_int32_one(name):
    obs = random_obs(3)  # includes unit_type and unit_hit_points, both wide
    packed = narrow.pack_observation(obs, FMT.screen_layers, FMT.minimap_layers)
    assert packed["feature_screen_high"].shape[1] == 2
    params = network(name)[1]
    apply = jitted_apply(name)
    same = jax.tree.map(np.array_equal, apply(params, obs), apply(params, packed))
    assert all(jax.tree.leaves(same))
