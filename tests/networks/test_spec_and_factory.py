"""NetworkSpec from the specs, the factory, and input validation."""

import pytest

from sc2jax.environment import ObservationFormat
from sc2jax.networks import (
    NETWORKS,
    ARFullyConv,
    AtariNet,
    FullyConv,
    FullyConvLSTM,
    NetworkSpec,
    make_network,
)
from tests.networks.helpers import FMT, SPEC, jitted_apply, network, random_obs


def test_spec_sizes_come_from_the_specs():
    spec = NetworkSpec.from_format(ObservationFormat(screen_size=(32, 24), minimap_size=16))
    assert spec.screen_size == (32, 24) and spec.minimap_size == (16, 16)
    assert len(spec.screen_layers) == 27 and len(spec.minimap_layers) == 11
    assert spec.num_functions == 573
    # screen, minimap, screen2 are (x, y); queued is 2 values; select_unit_id 500.
    assert spec.argument_sizes[:4] == ((32, 24), (16, 16), (32, 24), (2,))
    assert spec.argument_sizes[9] == (500,)
    assert spec.nonspatial == (("player", 11),)
    assert SPEC.point_argument_ids == (0, 1, 2)


def test_spec_rejects_bad_inputs():
    with pytest.raises(ValueError, match="unknown non-spatial key 'nope'.*allowed"):
        NetworkSpec.from_format(FMT, ("nope",))
    with pytest.raises(TypeError, match="ObservationFormat"):
        NetworkSpec.from_format({"screen_size": 16})
    spec = NetworkSpec.from_format(FMT, ("player", "available_actions_mask", "game_loop"))
    assert spec.nonspatial_size == 11 + 573 + 1


@pytest.mark.parametrize("name,cls", [("atari", AtariNet), ("fullyconv", FullyConv),
                                      ("fullyconv_lstm", FullyConvLSTM),
                                      ("arfullyconv", ARFullyConv)])
def test_make_network_by_name(name, cls):
    net = make_network(name, FMT, hidden=128)
    assert isinstance(net, cls) and net.spec == SPEC and net.hidden == 128


def test_make_network_unknown_name_lists_allowed():
    with pytest.raises(ValueError, match=r"unknown network 'resnet'.*'arfullyconv'.*'atari'"):
        make_network("resnet", FMT)
    with pytest.raises(TypeError, match="ObservationFormat or a NetworkSpec"):
        make_network("atari", 64)
    assert sorted(NETWORKS) == ["arfullyconv", "atari", "fullyconv", "fullyconv_lstm",
                               "raw_fullyconv"]


def test_wrong_observation_shape_names_the_key():
    apply = jitted_apply("atari")
    params = network("atari")[1]
    obs = random_obs(1)
    bad = dict(obs, feature_screen=obs["feature_screen"][:, :2])
    expected = r"feature_screen'\] has shape \(2, 2, 16, 16\); expected \[B, 3, 16, 16\]"
    with pytest.raises(ValueError, match=expected):
        apply(params, bad)
    unbatched = dict(obs, player=obs["player"][0])
    with pytest.raises(ValueError, match="player"):
        apply(params, unbatched)
    with pytest.raises(ValueError, match="no 'feature_minimap'"):
        apply(params, {k: v for k, v in obs.items() if k != "feature_minimap"})
