"""The SC2 API's messages on the fast protobuf runtime, and the action and observation
codecs (no network)."""

import subprocess
import sys

import numpy as np
import pytest

from sc2jax.environment import proto_actions, proto_observation
from sc2jax.environment.functions import FUNCTIONS, FunctionCall, FunctionType
from sc2jax.environment.protos import runtime, sc2api


def test_messages_load_on_the_fast_runtime_without_the_generated_modules():
    code = ("import sys, sc2jax.environment as e; assert 's2clientprotocol' not in str("
            "list(sys.modules)); from sc2jax.environment.protos import sc2api, runtime; "
            "sc2api.Request(id=1); "
            "assert not any(m.startswith('s2clientprotocol.') for m in sys.modules), 'pb2'; "
            "print(runtime())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() in ("upb", "cpp")
    assert runtime() in ("upb", "cpp")
    assert sc2api.Status.Value("in_game") == 3
    assert sc2api.ResponseCreateGame.Error.Value("InvalidMapPath") == 2
    with pytest.raises(AttributeError, match="NoSuchMessage"):
        _ = sc2api.NoSuchMessage


def _example_call(func):
    args = []
    for i, t in enumerate(func.args):
        if t.is_point:
            args.append([(3 * func.id + i) % 64, (7 * func.id + i) % 48])
        else:
            args.append([(func.id + i) % t.sizes[0]])
    return FunctionCall(func.id, args)


def test_every_function_round_trips_through_its_action_proto():
    for func in FUNCTIONS:
        call = _example_call(func)
        back = proto_actions.from_proto(sc2api.Action.FromString(
            proto_actions.to_proto(call).SerializeToString()))
        if func.general_id:  # A specific ability comes back as its general function.
            general = FUNCTIONS[back.function]
            assert general.ability_id == func.general_id, func
            assert general.function_type == func.function_type, func
            continue
        if func.function_type == FunctionType.select_rect:  # Corners are normalised.
            (x0, y0), (x1, y1) = call.arguments[1], call.arguments[2]
            call = FunctionCall(call.function, [call.arguments[0], [min(x0, x1), min(y0, y1)],
                                                [max(x0, x1), max(y0, y1)]])
        assert back == call, func


def test_actions_are_pysc2s_protos():
    attack = proto_actions.to_proto(FUNCTIONS.Attack_screen("queued", (3, 4)))
    command = attack.action_feature_layer.unit_command
    assert (command.ability_id, command.queue_command) == (3674, True)
    assert (command.target_screen_coord.x, command.target_screen_coord.y) == (3, 4)
    rect = proto_actions.to_proto(FUNCTIONS.select_rect("add", (9, 2), (1, 7)))
    corners = rect.action_feature_layer.unit_selection_rect.selection_screen_coord[0]
    assert (corners.p0.x, corners.p0.y, corners.p1.x, corners.p1.y) == (1, 2, 9, 7)
    group = proto_actions.to_proto(FUNCTIONS.select_control_group("set", 4))
    assert (group.action_ui.control_group.action,
            group.action_ui.control_group.control_group_index) == (2, 4)
    assert proto_actions.to_proto(FUNCTIONS.no_op()).ByteSize() == 0
    # An ability the interface does not know is a no_op, as in PySC2.
    unknown = sc2api.Action()
    unknown.action_feature_layer.unit_command.ability_id = 99999
    assert proto_actions.from_proto(unknown).function == FUNCTIONS.no_op.id


@pytest.mark.parametrize("scale,values,bits", [(2, [0, 1], 1), (256, [0, 255], 8),
                                                (1962, [0, 1961], 32), (16, [0, 300], 32)])
def test_images_round_trip_at_their_bit_depth(scale, values, bits):
    rng = np.random.default_rng(0)
    layer = rng.choice(values, size=(5, 11)).astype(np.int32)  # 55 bits: rows unpadded.
    image = proto_observation.encode_image(layer, scale)
    assert image.bits_per_pixel == bits
    np.testing.assert_array_equal(proto_observation.decode_image(image), layer)


def test_bad_images_are_rejected():
    image = proto_observation.encode_image(np.ones((4, 4), np.int32), 256)
    image.data = image.data[:-1]
    with pytest.raises(ValueError, match="4x4 at 8 bits has 15 bytes"):
        proto_observation.decode_image(image)
    image.bits_per_pixel = 12
    with pytest.raises(ValueError, match="bits_per_pixel 12"):
        proto_observation.decode_image(image)
    assert proto_observation.decode_image(sc2api.ImageData()).shape == (0, 0)


def test_available_actions_follow_pysc2s_rules_for_the_games_specific_abilities():
    player = np.zeros(11, np.int32)
    player[8] = 2  # army_count
    # The game reports Attack's specific ability (23) with requires_point.
    ids = proto_observation.available_actions([(23, True), (4, False)], player, "multi")
    names = {FUNCTIONS[int(i)].name for i in ids}
    assert names == {"no_op", "move_camera", "select_point", "select_rect",
                     "select_control_group", "select_unit", "select_army", "Attack_screen",
                     "Attack_minimap", "Stop_quick"}
    shown = proto_observation.available_actions([(23, True)], player, None,
                                                hide_specific_actions=False)
    assert {"Attack_Attack_screen", "Attack_Attack_minimap"} <= {
        FUNCTIONS[int(i)].name for i in shown}
