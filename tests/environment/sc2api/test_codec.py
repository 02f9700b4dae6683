"""The SC2 API's messages on the fast protobuf runtime, and the action and observation
codecs (no network)."""

import subprocess
import sys

import numpy as np
import pytest

from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, FunctionType
from sc2jax.environment.sc2api import proto_actions, proto_observation
from sc2jax.environment.sc2api.protos import runtime, sc2api


def test_messages_load_on_the_fast_runtime_without_the_generated_modules():
    code = ("import sys, sc2jax.environment as e; assert 's2clientprotocol' not in str("
            "list(sys.modules)); from sc2jax.environment.sc2api.protos import sc2api, runtime; "
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


def test_the_server_reports_the_games_specific_abilities():
    from sc2jax.environment.interface.functions import SPECIFIC_ABILITY

    # Every general ability of the simulator's units maps to a specific one of its own
    # general ability, so PySC2's rules give back the same functions.
    for general, specific in SPECIFIC_ABILITY.items():
        assert {f.general_id for f in FUNCTIONS if f.ability_id == specific} == {general}
    card = ("Attack_screen", "Attack_minimap", "Harvest_Gather_screen", "Stop_quick",
            "Smart_screen", "Build_Barracks_screen")
    mask = np.zeros(len(FUNCTIONS), bool)
    mask[[FUNCTIONS[name].id for name in card]] = True
    abilities = proto_observation.available_abilities(mask)
    assert sorted(abilities) == [(1, True), (4, False), (23, True), (295, True),
                                 (321, True)]
    player = np.zeros(11, np.int32)
    general = proto_observation.available_actions(abilities, player, "single")
    assert {FUNCTIONS[int(i)].name for i in general} >= set(card)
    specific = proto_observation.available_actions(abilities, player, "single",
                                                   hide_specific_actions=False)
    assert {"Attack_Attack_screen", "Harvest_Gather_SCV_screen", "Stop_Stop_quick"} <= {
        FUNCTIONS[int(i)].name for i in specific}


def _game_units():
    """A Barracks (64-bit tag, a tech lab, two Marines in training) on screen, and a
    damaged Marine off screen, as the game reports them."""
    response = sc2api.ResponseObservation()
    raw = response.observation.raw_data
    raw.player.camera.x, raw.player.camera.y = 40.0, 30.0
    barracks = raw.units.add(
        display_type=1, alliance=1, tag=4_303_355_905, unit_type=21, owner=1, facing=4.71,
        radius=1.8125, build_progress=1.0, cloak=3, is_on_screen=True, is_powered=False,
        is_active=True, health=1000.0, health_max=1000.0, add_on_tag=4_303_355_906)
    barracks.pos.x, barracks.pos.y = 41.5, 27.5
    barracks.orders.add(ability_id=560, progress=0.55)
    barracks.orders.add(ability_id=560)
    lab = raw.units.add(display_type=1, alliance=1, tag=4_303_355_906, unit_type=37,
                        owner=1, radius=1.0, build_progress=0.25, cloak=3, is_on_screen=True,
                        health=100.0, health_max=400.0)
    lab.pos.x, lab.pos.y = 44.0, 27.0
    marine = raw.units.add(display_type=1, alliance=4, tag=7, unit_type=48, owner=2,
                           facing=1.5, radius=0.375, cloak=3, is_on_screen=False,
                           health=29.7, health_max=45.0, weapon_cooldown=9.5,
                           buff_ids=[5, 27])
    marine.pos.x, marine.pos.y = 10.25, 60.0
    return response


def test_unit_lists_are_pysc2s_rows_of_the_games_units():
    from sc2jax.environment.interface.observation_tables import FeatureUnit as F
    from sc2jax.environment.interface.specs import ObservationFormat

    fmt = ObservationFormat(screen_size=(48, 32), minimap_size=64, use_feature_units=True,
                            use_raw_units=True)
    obs = proto_observation.decode(_game_units(), fmt, "Simple64", map_size=(88, 96))
    screen, raw = obs["feature_units"], obs["raw_units"]
    assert screen.dtype == raw.dtype == np.int64
    assert screen.shape == (2, len(F)) and raw.shape == (3, len(F))
    barracks, lab, marine = raw
    # Screen: 48 px span 24 world units (2 px per unit) centred on the camera.
    assert screen[0, F.x] == (41.5 - 40) * 2 + 24 and screen[0, F.y] == (30 - 27.5) * 2 + 16
    assert screen[0, F.radius] == 3 and screen[0, F.tag] == 0  # Tags in raw units only.
    # Raw units: PySC2 v4's raw grid, by default the map size (88, 96), each axis scaled
    # by its resolution over the map's longer side (96), y down.
    assert (barracks[F.x], barracks[F.y]) == (int(41.5 * 88 / 96), int(96 - 27.5))
    assert barracks[F.radius] == int(1.8125 * 88 / 96)
    assert barracks[F.tag] == 4_303_355_905  # 64-bit tags survive.
    assert barracks[F.facing] == 4 and barracks[F.order_length] == 2
    assert barracks[F.order_progress_0] == 55 and barracks[F.order_progress_1] == 0
    # Orders as raw functions, PySC2's RAW_ABILITY_ID_TO_FUNC_ID (560: Train_Marine).
    assert barracks[F.order_id_0] == barracks[F.order_id_1] == 511
    assert barracks[F.order_id_2] == 0 and screen[0, F.order_id_0] == 511
    assert barracks[F.addon_unit_type] == 37 and barracks[F.active] == 1
    assert barracks[F.build_progress] == 100 and lab[F.build_progress] == 25
    assert lab[F.health_ratio] == 63 and barracks[F.health_ratio] == 255
    assert (marine[F.alliance], marine[F.owner], marine[F.is_on_screen]) == (4, 2, 0)
    assert marine[F.health] == 29 and marine[F.health_ratio] == int(29.7 / 45 * 255)
    assert marine[F.weapon_cooldown] == 9
    assert (marine[F.buff_id_0], marine[F.buff_id_1]) == (5, 27)
    with pytest.raises(ValueError, match="raw_units needs the map size"):
        proto_observation.decode(_game_units(), fmt, "Simple64")
