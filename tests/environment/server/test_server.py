"""The simulator's SC2-API server and sc2jax's client, over a real websocket: requests,
framing, faults, the launcher and the install layout (the episodes themselves are
checked in sc2api/test_loopback.py)."""

import os
import pathlib
import re
import subprocess
import sys
import threading
import time

import jax
import numpy as np
import pytest
import websocket
from websockets.sync.server import serve

from sc2jax.environment import make
from sc2jax.environment.engine.rules.state import Order, Owner
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall
from sc2jax.environment.interface.map_names import LADDER_MAP_PATHS
from sc2jax.environment.interface.observation_tables import TERRAN
from sc2jax.environment.interface.players import Difficulty
from sc2jax.environment.sc2api import proto_actions
from sc2jax.environment.sc2api.controller import Controller, RequestError
from sc2jax.environment.sc2api.game_env import Bot, GameEnv
from sc2jax.environment.sc2api.launcher import launch, sc2path
from sc2jax.environment.sc2api.protos import sc2api
from sc2jax.environment.server import Sc2ApiServer, programs
from sc2jax.environment.server import websocket as server_module
from sc2jax.environment.server.install_layout import write_sc2path
from tests.environment.server.helpers import join_beacon

SIZES = dict(screen_size=16, minimap_size=16)


def test_requests_out_of_order_and_bad_setups_get_errors(server):
    controller = Controller.connect("127.0.0.1", server.port)
    try:
        with pytest.raises(RequestError, match="step needs status in_game, in_replay, ended; the "
                                               "status is launched"):
            controller.step(8)
        with pytest.raises(RequestError, match="InvalidMapPath.*'Simple64.SC2Map' is not a "
                                               "map of the simulator"):
            controller.create_game(map_path="Simple64.SC2Map")
        bot = Bot("zerg", "easy").setup()
        with pytest.raises(RequestError, match="InvalidPlayerSetup"):
            controller.create_game(map_path="MoveToBeacon.SC2Map", players=[
                sc2api.PlayerSetup(type=1), bot])
        controller.create_game(map_path="mini_games/MoveToBeacon.SC2Map", random_seed=1)
        options = sc2api.InterfaceOptions()
        with pytest.raises(RequestError, match="MissingOptions"):
            controller.join_game(options)
        options.feature_layer.width = 32
        options.feature_layer.resolution.x = options.feature_layer.resolution.y = 24
        options.feature_layer.minimap_resolution.x = 16
        options.feature_layer.minimap_resolution.y = 16
        with pytest.raises(RequestError, match="FeatureUnsupported.*width 32"):
            controller.join_game(options)
        options.feature_layer.width = 24
        options.feature_layer.resolution.x = 8
        with pytest.raises(RequestError, match="FeatureUnsupported.*16..256"):
            controller.join_game(options)
        options.feature_layer.resolution.x = 24
        assert controller.join_game(options).player_id == 1
        info = controller.game_info()
        assert info.map_name == "MoveToBeacon"
        assert info.options == options
        assert info.player_info[0].race_requested == sc2api.Race.Value("Terran")
        assert (info.start_raw.map_size.x, info.start_raw.map_size.y) == (64, 64)
        assert {u.name for u in controller.data().units} >= {"Marine", "Beacon_Terran"}
        with pytest.raises(RequestError, match="step count 0 is outside"):
            controller.step(0)
        with pytest.raises(RequestError, match="start_replay needs status launched"):
            controller.start_replay(replay_data=controller.save_replay(), options=options)
        controller.leave()
        for data, message in ((b"MPQ\x1b...", "InvalidReplayData.*StarCraft II replay"),
                              (b'{"sc2jax_replay": 1, "key"}', "damaged simulator replay")):
            with pytest.raises(RequestError, match=message):
                controller.replay_info(replay_data=data)
        with pytest.raises(RequestError, match="MissingReplay"):
            controller.start_replay()
        assert controller.status == sc2api.Status.Value("launched")
    finally:
        controller.close()


def test_a_saved_replay_plays_back_the_same_observations_and_actions(server):
    controller = Controller.connect("127.0.0.1", server.port)
    try:
        options = join_beacon(controller)
        calls = [FunctionCall(FUNCTIONS.select_army.id, [[0]]),
                 FunctionCall(FUNCTIONS.Move_screen.id, [[0], [3, 12]]), None,
                 FunctionCall(FUNCTIONS.Move_screen.id, [[1], [9, 2]])]
        live = []
        for call in calls:
            live.append(controller.observe().observation)
            if call is not None:
                controller.actions([proto_actions.to_proto(call)])
            controller.step(8)
        data = controller.save_replay()
        controller.leave()
        info = controller.replay_info(replay_data=data)
        assert (info.map_name, info.game_duration_loops) == ("MoveToBeacon", 32)
        options.feature_layer.resolution.x = 24
        with pytest.raises(RequestError, match="recorded resolutions, screen \\(16, 16\\)"):
            controller.start_replay(replay_data=data, options=options)
        options.feature_layer.resolution.x = 16
        controller.start_replay(replay_data=data, options=options)
        assert controller.status == sc2api.Status.Value("in_replay")
        for t in range(len(calls)):
            watched = controller.observe()
            assert watched.observation == live[t]
            if t:
                before = calls[t - 1]
                assert [proto_actions.from_proto(a) for a in watched.actions] == (
                    [before] if before is not None else [])
            controller.step(8)
        assert controller.status == sc2api.Status.Value("ended")
        watched = controller.observe()
        assert [proto_actions.from_proto(a) for a in watched.actions] == calls[-1:]
        controller.leave()
    finally:
        controller.close()


def test_actions_get_honest_results_and_a_flood_is_refused(server):
    controller = Controller.connect("127.0.0.1", server.port)
    result = sc2api.ActionResult.Name
    try:
        join_beacon(controller)
        raw = sc2api.Action()
        raw.action_raw.camera_move.center_world_space.x = 10
        chat = sc2api.Action()
        chat.action_chat.message = "gl hf"
        unknown = sc2api.Action()
        unknown.action_feature_layer.unit_command.ability_id = 999_999
        army = proto_actions.to_proto(FunctionCall(FUNCTIONS.select_army.id, [[0]]))
        outside = proto_actions.to_proto(FunctionCall(FUNCTIONS.Move_screen.id, [[0], [40, 3]]))
        replies = controller.actions([raw, chat, unknown, army, outside]).result
        assert [result(r) for r in replies] == ["NotSupported", "NotSupported",
                                                "NotSupported", "Success", "Error"]
        with pytest.raises(RequestError, match="64 actions with 1 already waiting for the "
                                               "next step; at most 64 per step"):
            controller.actions([army] * 64)
        controller.actions([army] * 63)  # 64 in all: allowed
        while controller.step(8) and controller.status != sc2api.Status.Value("ended"):
            pass
        assert [result(r) for r in controller.actions([army]).result] == ["Error"]
    finally:
        controller.close()


def test_one_compiled_step_runs_every_count_and_program_sets_are_bounded(server):
    controller = Controller.connect("127.0.0.1", server.port)
    try:
        join_beacon(controller)
        loops = 0
        for count in (1, 7, 300, 8, 10_000):
            loops += count
            assert controller.step(count).simulation_loop == loops
        assert server.service._programs.step._cache_size() == 1
    finally:
        controller.close()
    # Program sets are only made here, not compiled (that happens at their first call).
    formats = [specs.ObservationFormat(17 + i, 17) for i in range(programs.MAX_FORMATS + 1)]
    first = programs.programs("MoveToBeacon", formats[0])
    assert programs.programs("MoveToBeacon", formats[0]) is first
    for fmt in formats[1:]:
        programs.programs("MoveToBeacon", fmt)
    assert programs.programs.cache_info().currsize == programs.MAX_FORMATS
    assert programs.programs("MoveToBeacon", formats[0]) is not first  # Dropped, remade.


def test_a_camera_width_that_is_not_a_number_is_refused(server):
    controller = Controller.connect("127.0.0.1", server.port)
    try:
        controller.create_game(map_path="MoveToBeacon.SC2Map")
        options = sc2api.InterfaceOptions()
        options.feature_layer.width = float("nan")
        options.feature_layer.resolution.x = options.feature_layer.resolution.y = 16
        options.feature_layer.minimap_resolution.x = 16
        options.feature_layer.minimap_resolution.y = 16
        with pytest.raises(RequestError, match="FeatureUnsupported.*width nan"):
            controller.join_game(options)
    finally:
        controller.close()


def test_a_replay_the_server_would_not_have_written_is_refused(server):
    from sc2jax.environment.server.replays import Replay

    controller = Controller.connect("127.0.0.1", server.port)
    army = FunctionCall(FUNCTIONS.select_army.id, [[0]])
    good = dict(map_name="MoveToBeacon", map_path="", key=[0, 5], screen_size=(16, 16),
                minimap_size=(16, 16), steps=[(8, [army])], result=None)
    try:
        for change, message in ((dict(map_name="Simple64"), "not a mini-game"),
                                (dict(key=[1]), "is not two 32-bit words"),
                                (dict(steps=[(8, [army] * 65)]), "at most 64 calls"),
                                (dict(steps=[(0, [])]), "runs 0 loops"),
                                (dict(steps=[(8, [FunctionCall(331, [[0], [99, 0]])])]),
                                 "outside the allowed range")):
            data = Replay(**{**good, **change}).to_bytes()
            with pytest.raises(RequestError, match=f"InvalidReplayData.*{message}"):
                controller.replay_info(replay_data=data)
        assert controller.replay_info(replay_data=Replay(**good).to_bytes()).map_name == (
            "MoveToBeacon")
    finally:
        controller.close()


def test_the_game_belongs_to_the_connection_that_started_it(server):
    owner = Controller.connect("127.0.0.1", server.port)
    other = Controller.connect("127.0.0.1", server.port)
    try:
        join_beacon(owner)
        owner.step(8)
        for request in (lambda: other.step(8), other.observe, other.leave,
                        lambda: other.create_game(map_path="MoveToBeacon.SC2Map")):
            with pytest.raises(RequestError, match="belongs to another connection; this one "
                                                   "may only ping"):
                request()
        assert other.ping().base_build == 75689
        refused = other._exchange("quit", sc2api.Request(id=99, quit=sc2api.RequestQuit()))
        assert "belongs to another connection" in refused.error[0]
        owner.close()  # Gone without leaving: the game is left for the next client.
        deadline = time.time() + 30
        while True:
            try:
                join_beacon(other)
                break
            except RequestError:
                assert time.time() < deadline, "the owner's game was not left"
                time.sleep(0.1)
        assert other.step(8).simulation_loop == 8
    finally:
        owner.close()
        other.close()


def test_foreign_pages_and_too_many_connections_are_refused():
    server = Sc2ApiServer(port=0, max_connections=2)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    url = f"ws://127.0.0.1:{server.port}/sc2api"
    open_ = []
    try:
        with pytest.raises(websocket.WebSocketBadStatusException, match="403"):
            websocket.create_connection(url, origin="https://example.com", timeout=30)
        open_.append(websocket.create_connection(url, origin=f"http://localhost:{server.port}",
                                                 timeout=30))
        open_.append(websocket.create_connection(url, suppress_origin=True, timeout=30))
        time.sleep(0.2)  # Both handlers have started.
        with pytest.raises(websocket.WebSocketBadStatusException, match="503"):
            websocket.create_connection(url, timeout=30)
    finally:
        for socket in open_:
            socket.close()
        server.shutdown()


def test_text_frames_that_are_not_utf8_are_served_and_replies_are_binary(server):
    # Known clients (PySC2) send the serialized request in TEXT frames.
    socket = websocket.create_connection(f"ws://127.0.0.1:{server.port}/sc2api", timeout=30)
    try:
        data = sc2api.Request(id=200, ping=sc2api.RequestPing()).SerializeToString()
        with pytest.raises(UnicodeDecodeError):
            data.decode("utf-8")
        socket.send(data, opcode=websocket.ABNF.OPCODE_TEXT)  # Bytes as they are.
        opcode, reply = socket.recv_data()
        assert opcode == websocket.ABNF.OPCODE_BINARY
        response = sc2api.Response.FromString(reply)
        assert response.id == 200 and response.ping.base_build == 75689
        # Raw invalid UTF-8 in a TEXT frame.
        frame = websocket.ABNF.create_frame(b"\x9a\x01\x05\xff\xfe",
                                            websocket.ABNF.OPCODE_TEXT)
        socket.send_frame(frame)
        response = sc2api.Response.FromString(socket.recv_data()[1])
        assert response.error  # A malformed request, answered with an error.
    finally:
        socket.close()


def test_malformed_truncated_and_random_requests_never_crash_the_server(server):
    rng = np.random.default_rng(0)
    good = sc2api.Request(id=5, step=sc2api.RequestStep(count=8)).SerializeToString()
    frames = [good[:n] for n in range(len(good))]
    frames += [rng.bytes(int(rng.integers(1, 200))) for _ in range(300)]
    # Valid protobuf with random field values.
    for _ in range(100):
        request = sc2api.Request(id=int(rng.integers(1, 1000)))
        kind = rng.choice(["create_game", "join_game", "action", "step", "observation",
                           "game_info", "restart_game", "leave_game", "debug", "query"])
        getattr(request, kind).SetInParent()
        if kind == "action":
            action = request.action.actions.add()
            action.action_feature_layer.unit_command.ability_id = int(rng.integers(0, 4000))
            action.action_feature_layer.unit_command.target_screen_coord.x = int(
                rng.integers(-5, 1000))
        frames.append(request.SerializeToString())
    socket = websocket.create_connection(f"ws://127.0.0.1:{server.port}/sc2api", timeout=30)
    try:
        for frame in frames:
            socket.send_binary(frame)
            sc2api.Response.FromString(socket.recv())  # Always a parseable reply.
    finally:
        socket.close()
    controller = Controller.connect("127.0.0.1", server.port)
    assert controller.ping().base_build == 75689
    controller.close()


def test_oversized_frames_close_the_connection_and_the_server_goes_on():
    server = Sc2ApiServer(port=0, max_message_bytes=1024)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        socket = websocket.create_connection(f"ws://127.0.0.1:{server.port}/sc2api",
                                             timeout=10)
        socket.send_binary(b"\x00" * 4096)
        assert socket.recv() == "" and not socket.connected  # Closed, code 1009.
        controller = Controller.connect("127.0.0.1", server.port)
        assert controller.ping().game_version == "4.10.0"
        controller.quit()
        thread.join(10)
        assert not thread.is_alive()  # RequestQuit stops the server.
    finally:
        server.shutdown()


def test_other_paths_are_not_found(server):
    with pytest.raises(websocket.WebSocketBadStatusException, match="404"):
        websocket.create_connection(f"ws://127.0.0.1:{server.port}/other", timeout=10)


def test_a_stalled_server_gives_a_timeout_not_a_hang():
    def stall(connection):
        connection.recv()
        time.sleep(5)

    with serve(stall, "127.0.0.1", 0) as stalled:
        thread = threading.Thread(target=stalled.serve_forever, daemon=True)
        thread.start()
        port = stalled.socket.getsockname()[1]
        controller = Controller.connect("127.0.0.1", port, timeout_seconds=0.5)
        start = time.monotonic()
        with pytest.raises(TimeoutError, match="ping: no reply within 0.5 s"):
            controller.ping()
        assert time.monotonic() - start < 3
        stalled.shutdown()


def test_nothing_listening_gives_a_connection_error():
    with pytest.raises(ConnectionError, match="no SC2 API at ws://127.0.0.1:1/sc2api"):
        Controller.connect("127.0.0.1", 1, connect_seconds=1)


@pytest.mark.slow
def test_an_install_layout_launches_the_server_and_survives_a_killed_game(tmp_path):
    root = write_sc2path(tmp_path / "StarCraftII")
    assert (root / "Maps" / "mini_games" / "BuildMarines.SC2Map").is_file()
    assert os.access(root / "Versions" / "Base75689" / "SC2_x64", os.X_OK)
    games = []

    def connect():
        games.append(launch(root, connect_seconds=120))
        return games[-1].controller

    env = GameEnv(connect, "MoveToBeacon", random_seed=0, **SIZES)
    try:
        first = env.reset()
        assert first.observation["feature_screen"].shape == (27, 16, 16)
        env.step(FUNCTIONS.select_army("select"))
        games[0].process.kill()  # The game dies mid-episode.
        with pytest.raises(ConnectionError, match="connection to the game was lost"):
            env.step(FUNCTIONS.no_op())
        again = env.reset()  # A working restart: a new game process.
        assert len(games) == 2 and games[1].running()
        np.testing.assert_array_equal(again.observation["feature_screen"],
                                      first.observation["feature_screen"])
    finally:
        env.close()
    assert not games[1].running()


def test_launcher_errors_name_what_is_missing(tmp_path):
    with pytest.raises(FileNotFoundError, match="no StarCraft II install at"):
        sc2path(tmp_path / "nowhere")
    root = write_sc2path(tmp_path / "sc2")
    with pytest.raises(FileNotFoundError, match="build 12345 is not installed.*75689"):
        launch(root, build=12345)


def test_game_env_and_make_reject_bad_settings_before_connecting():
    def never():
        raise AssertionError("connected")

    with pytest.raises(ValueError, match="bot difficulty 11"):
        GameEnv(never, "Simple64", bot=Bot("zerg", 11))
    with pytest.raises(ValueError, match="race 'elf'"):
        GameEnv(never, "MoveToBeacon", race="elf")
    with pytest.raises(ValueError, match="step_mul must be an int >= 1"):
        GameEnv(never, "MoveToBeacon", step_mul=0)
    with pytest.raises(ValueError, match="score_index"):
        GameEnv(never, "MoveToBeacon", score_index=13)
    with pytest.raises(ValueError, match="num_envs"):
        make("MoveToBeacon", backend="sc2", num_envs=2)
    with pytest.raises(ValueError, match="backend 'real'"):
        make("MoveToBeacon", backend="real")


def _real_install() -> pathlib.Path | None:
    try:
        root = sc2path()
    except FileNotFoundError:
        return None
    binary = next(root.glob("Versions/Base*/SC2_x64"), None)
    if binary is None or binary.read_bytes()[:2] == b"#!":  # Our own stand-in.
        return None
    return root


@pytest.mark.sc2
@pytest.mark.skipif(_real_install() is None, reason="needs a StarCraft II install")
def test_the_real_game_plays_move_to_beacon():
    env = make("MoveToBeacon", backend="sc2", seed=1, **SIZES)
    try:
        timestep = env.reset()
        assert FUNCTIONS.select_army.id in timestep.observation["available_actions"]
        timestep = env.step(FUNCTIONS.select_army("select"))
        assert timestep.observation["multi_select"].shape[0] + timestep.observation[
            "single_select"].shape[0] >= 1
    finally:
        env.close()


def test_the_server_takes_the_games_command_line_and_writes_the_layout(tmp_path):
    # `-headlessNoRender` must not be read as -h; the game's other arguments are ignored.
    args, ignored = server_module._parse(
        ["-listen", "127.0.0.1", "-port", "5123", "-dataDir", "/sc2/", "-tempDir", "/t/",
         "-headlessNoRender", "-displayMode", "0"])
    assert (args.host, args.port) == ("127.0.0.1", 5123)
    assert "-headlessNoRender" in ignored and "-dataDir" in ignored
    lines = []
    assert server_module.main(["--write-sc2path", str(tmp_path / "layout")],
                              announce=lines.append) == 0
    assert lines == [f"wrote {tmp_path / 'layout'}"]
    assert (tmp_path / "layout" / "Versions" / "Base75689" / "SC2_x64").is_file()
    with pytest.raises(SystemExit, match="--port 70000 is outside 0..65535"):
        server_module.main(["--port", "70000"])


def test_quit_with_another_connection_open_exits_the_process_cleanly():
    server = subprocess.Popen([sys.executable, "-m", "sc2jax.environment.server", "--port",
                               "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
    try:
        port = int(re.search(r":(\d+)/sc2api", server.stdout.readline()).group(1))
        idle = Controller.connect("127.0.0.1", port)  # Open, silent, never closed by us.
        quitting = Controller.connect("127.0.0.1", port)
        assert idle.ping().base_build and quitting.ping().base_build
        reply = quitting._exchange("quit", sc2api.Request(id=5, quit=sc2api.RequestQuit()))
        assert reply.status == sc2api.Status.Value("quit")  # Answered before it stops.
        quitting.close()
        assert server.wait(timeout=30) == 0
        assert "Traceback" not in server.stderr.read()
        with pytest.raises(ConnectionError):
            idle.ping()
    finally:
        server.kill()


@pytest.mark.slow
def test_a_client_plays_a_ladder_map_against_the_simulators_computer():
    server = Sc2ApiServer(port=0, melee_slots=256)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    env = GameEnv(lambda: Controller.connect("127.0.0.1", server.port), "Acropolis",
                  map_path=LADDER_MAP_PATHS["Acropolis"], bot=Bot("terran", "easy"),
                  random_seed=7, **SIZES)
    try:
        ts = env.reset()
        assert ts.observation["player"][0] == 1 and env._races == (TERRAN, TERRAN)
        info = server.service  # The game the client created: the Easy computer plays it.
        assert info._map_name == "Acropolis" and info._computer == Difficulty.easy
        for _ in range(2):
            ts = env.step(FUNCTIONS.no_op())
        assert ts.observation["game_loop"][0] == 16 and ts.reward == 0.0
        units = jax.device_get(info._state.units)
        enemy_scvs = units.alive & (units.owner == Owner.ENEMY) & (units.type == UnitType.SCV)
        # It acted on its first step: its idle SCVs went to mine (docs/full_game.md).
        assert enemy_scvs.sum() == 12 and (units.orders[enemy_scvs, 0] == Order.GATHER).all()
        with pytest.raises(RequestError, match="replays of the mini-games only"):
            env._controller.save_replay()
    finally:
        env.close()
        server.shutdown()


def test_ladder_maps_take_one_computer_the_simulator_plays(server):
    controller = Controller.connect("127.0.0.1", server.port)
    try:
        participant = sc2api.PlayerSetup(type=sc2api.PlayerType.Value("Participant"))
        for bot, message in ((Bot("zerg", "easy"), "Terran .* got race 'zerg'"),
                             (Bot("terran", "very_hard"), "plays difficulties .*, got 7"),
                             (Bot("terran", "easy", "rush"), "build 'rush'")):
            with pytest.raises(RequestError, match=f"InvalidPlayerSetup.*{message}"):
                controller.create_game(map_path=LADDER_MAP_PATHS["Triton"],
                                       players=[participant, bot.setup()])
        with pytest.raises(RequestError, match="InvalidPlayerSetup.*at most one Computer"):
            controller.create_game(map_path="Acropolis LE", players=[
                participant, Bot("terran", "easy").setup(), Bot("terran", "easy").setup()])
        controller.create_game(map_path="Ladder2019Season2/KingsCoveLE.SC2Map",
                               players=[participant, Bot("random", "hard").setup()])
        assert server.service._map_name == "KingsCove"
        assert server.service._computer == Difficulty.hard
    finally:
        controller.close()
