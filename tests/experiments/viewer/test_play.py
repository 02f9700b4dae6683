"""Human play without a browser: clicks as PySC2 calls, the session, and the server's
requests."""

import json
import pathlib
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request

import numpy as np
import pytest

from sc2jax.environment.engine.compiled import simulator
from sc2jax.environment.engine.human_view import HumanView
from sc2jax.environment.episodes import check_replay, replay
from sc2jax.environment.interface.camera import Camera, Minimap
from sc2jax.environment.interface.functions import FUNCTIONS, NUM_FUNCTIONS
from sc2jax.experiments.viewer.inputs import call_for_click, view_to_world
from sc2jax.experiments.viewer.server import ViewerServer
from sc2jax.experiments.viewer.session import Playback, PlaySession
from tests.environment.helpers import SMALL, small_sim

CAMERA = np.float32([33.0, 25.0])
REPLAYS = pathlib.Path(__file__).parents[4] / "shared" / "replays"  # ../shared


def _views(map_name="MoveToBeacon"):
    sim = small_sim(map_name)
    w, h = sim.game.geometry.size
    return HumanView(sim, 384), HumanView(sim, 192, (0.0, 0.0, float(w), float(h)))


def _available(*functions):
    mask = np.zeros(NUM_FUNCTIONS, bool)
    mask[[FUNCTIONS[f].id for f in functions]] = True
    return mask


def test_clicks_become_the_calls_a_player_means():
    view, minimap_view = _views()
    camera, minimap = Camera(SMALL.screen_size), Minimap(SMALL.minimap_size, (64, 64))
    x, y = 150.0, 100.0
    world = view_to_world(view, x, y)
    screen = [int(v) for v in camera.world_to_pixel(CAMERA, np.float32([world]))[0]]
    everything = np.ones(NUM_FUNCTIONS, bool)

    def click(**kw):
        return call_for_click({"pane": "view", "x": x, "y": y, **kw}, view, minimap_view,
                              CAMERA, kw.pop("available", everything))

    assert click(kind="select") == FUNCTIONS.select_point("select", screen)
    assert click(kind="select", shift=True) == FUNCTIONS.select_point("toggle", screen)
    assert click(kind="smart", shift=True) == FUNCTIONS.Smart_screen([1], screen)
    move = call_for_click({"pane": "view", "kind": "smart", "x": x, "y": y}, view,
                          minimap_view, CAMERA, _available("Move_screen"))
    assert move == FUNCTIONS.Move_screen([0], screen)
    with pytest.raises(ValueError, match="select a unit first"):
        call_for_click({"pane": "view", "kind": "smart", "x": x, "y": y}, view,
                       minimap_view, CAMERA, _available("no_op"))
    # A drag: the rectangle's corners sorted.
    corner = view_to_world(view, 100.0, 160.0)
    other = [int(v) for v in camera.world_to_pixel(CAMERA, np.float32([corner]))[0]]
    rect = click(kind="rect", x2=100.0, y2=160.0)
    assert rect == FUNCTIONS.select_rect(0, [min(screen[0], other[0]), min(screen[1], other[1])],
                                         [max(screen[0], other[0]), max(screen[1], other[1])])
    # A chosen function at the point: Attack_minimap takes the minimap's pixel.
    mini = [int(v) for v in minimap.world_to_pixel(np.float32([world]))[0]]
    assert click(kind="point", function="Attack_minimap") == FUNCTIONS.Attack_minimap([0], mini)
    # The minimap: a left click moves the camera there.
    mx, my = 40.0, 90.0
    target = view_to_world(minimap_view, mx, my)
    expected = [int(v) for v in minimap.world_to_pixel(np.float32([target]))[0]]
    assert call_for_click({"pane": "minimap", "kind": "select", "x": mx, "y": my}, view,
                          minimap_view, CAMERA, everything) == FUNCTIONS.move_camera(expected)


def test_bad_clicks_are_refused():
    view, minimap_view = _views("FindAndDefeatZerglings")
    everything = np.ones(NUM_FUNCTIONS, bool)
    # Far from the camera's rectangle: off the screen.
    with pytest.raises(ValueError, match="off the screen"):
        call_for_click({"pane": "view", "kind": "select", "x": 2.0, "y": 2.0}, view,
                       minimap_view, CAMERA, everything)
    for click, match in (({"pane": "view", "kind": "jump", "x": 1, "y": 1}, "kind in"),
                         ({"pane": "view", "kind": "select"}, "numeric x and y"),
                         ({"pane": "view", "kind": "point", "function": "Nope", "x": 150,
                           "y": 100}, "unknown function"),
                         ({"pane": "minimap", "kind": "point", "function": "Move_screen",
                           "x": 5, "y": 5}, "click the view")):
        with pytest.raises(ValueError, match=match):
            call_for_click(click, view, minimap_view, CAMERA, everything)


def _request(address, path, body=None):
    data = None if body is None else json.dumps(body).encode()
    try:
        with urllib.request.urlopen(address + path, data, timeout=30) as reply:
            return reply.status, reply.read()
    except urllib.error.HTTPError as error:
        return error.code, error.read()


@pytest.mark.slow
def test_a_person_plays_an_episode_that_replays_exactly(tmp_path):
    # 30 steps of 64 game loops: MoveToBeacon's 1,920.
    sim = simulator("MoveToBeacon", SMALL, 64, 0, 1.0, 1.0, False)
    session = PlaySession(sim, seed=2, layers=sim.fmt.screen_layers[:2])
    with pytest.raises(ValueError, match="not available now"):
        session.submit(FUNCTIONS.Move_screen([0], [5, 5]))
    with pytest.raises(ValueError, match="Move_screen"):
        session.submit((FUNCTIONS.Move_screen.id, [[0]]))  # An argument missing.
    session.submit(FUNCTIONS.select_army([0]))
    session.step()
    assert session.last_call == "select_army(0)"
    session.submit(FUNCTIONS.Move_screen([0], [20, 12]))
    for _ in range(40):  # To the episode's end and into the next.
        session.step()
    assert len(session.episodes) == 1
    episode = session.episodes[0]
    assert episode.num_steps == 30 and episode.agent == "human"
    check_replay(episode, replay(episode)[1])
    frame = session.frame()
    assert frame.status["episode"] == 2 and frame.view.shape == (302, 384, 3)
    # The episode plays back, step by step.
    playback = Playback(episode, width=128)
    playback.seek(10)
    assert playback.frame().status["step"] == 10
    playback.seek(99)
    assert playback.frame().status["step"] == 30

    server = ViewerServer(port=0, speed=16.0, paused=True).start(session)
    try:
        address = server.address
        code, body = _request(address, "api/status")
        status = json.loads(body)
        assert code == 200 and status["paused"] and status["map"] == "MoveToBeacon"
        assert [f["name"] for f in status["available"]][:2] == ["no_op", "move_camera"]
        code, body = _request(address, "api/image/view.png")
        assert code == 200 and body[:4] == b"\x89PNG"
        for path, request, match in (
                ("api/act", {"function": "Attack_screen", "arguments": [[0], [1, 1]]},
                 "not available"),
                ("api/control", {"speed": 1000}, "speed must be in"),
                ("api/control", {"jump": 1}, "control request takes keys"),
                ("api/control", {"seek": 3}, "seek takes")):
            code, body = _request(address, path, request)
            assert code == 400 and match in json.loads(body)["error"], body
        assert _request(address, "setup.cfg")[0] == 404  # Only its own assets.
        before = status["step"]
        assert _request(address, "api/control", {"step": 2})[0] == 200
        deadline = time.monotonic() + 30
        while json.loads(_request(address, "api/status")[1])["step"] < before + 2:
            assert time.monotonic() < deadline, "the server did not step"
            time.sleep(0.05)
        with pytest.raises(ValueError, match="in use"):
            ViewerServer(port=int(address.rsplit(":", 1)[1].strip("/")))
    finally:
        server.close()


@pytest.mark.slow
def test_play_refuses_bad_flags_before_compiling():
    for flag, match in (("--map=Nope", "--map='Nope' is unknown"),
                        ("--agent=/no/such/run", "neither one of"),
                        ("--speed=0", "--speed must be in"),
                        ("--port=70000", "--port must be in")):
        out = subprocess.run([sys.executable, "-m", "sc2jax.experiments.play", flag],
                             capture_output=True, text=True, timeout=120)
        assert out.returncode != 0 and match in out.stderr, (flag, out.stderr)
    out = subprocess.run([sys.executable, "-m", "sc2jax.experiments.play",
                          "--episode=/no/such/file.npz"], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode != 0 and "no episode file" in out.stderr
    with socket.socket() as taken:  # A port in use, refused before anything compiles.
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = subprocess.run([sys.executable, "-m", "sc2jax.experiments.play",
                              f"--port={port}"], capture_output=True, text=True, timeout=120)
    assert out.returncode != 0 and f"port {port} on 127.0.0.1 is in use" in out.stderr


@pytest.mark.slow
@pytest.mark.skipif(not REPLAYS.is_dir(), reason=f"the replays are not at {REPLAYS}")
def test_a_human_replay_is_shown_as_its_player_saw_it():
    from sc2jax.experiments.viewer.replays import ReplayPlayback
    from sc2jax.replay_sl import label_players, open_replay, read_metadata

    path = REPLAYS / "asus_rog" / "0001_KairosJunction.SC2Replay"
    with pytest.raises(ValueError, match="not one of the replay's players"):
        ReplayPlayback(path, player_id=3)
    playback = ReplayPlayback(path, player_id=2, width=256)
    replay = open_replay(path)
    labels = label_players(replay, read_metadata(replay), [2])[2]
    assert playback.length == len(labels.steps)
    playback.seek(1500)
    frame = playback.frame()
    assert frame.status["step"] == 1500 and frame.status["mode"] == "replay"
    assert frame.status["game_loop"] == labels.steps[1500].game_loop
    assert frame.status["last_call"].split("(")[0] == FUNCTIONS[
        labels.steps[1500].call.function].name
    assert frame.view.shape == (256, 256, 3) and len(frame.panels) == 38
    assert (frame.view == 255).all(axis=-1).any()  # The camera's rectangle.
    # The player's own units are drawn in the player's colour.
    assert (frame.view == [0, 142, 0]).all(axis=-1).any()


@pytest.mark.slow
def test_a_trained_run_is_watched_in_its_own_format(tmp_path):
    from sc2jax.experiments.training import evaluation, trainer
    from tests.experiments.training.test_training import TINY

    run = str(tmp_path / "run")
    trainer.train(TINY, run, log=lambda _: None, progress=False)
    trained = trainer.trained_agent(run, map_name="DefeatRoaches")  # Ignored: A3C runs
    assert trained.sim.map_name == "MoveToBeacon" and trained.name == "atari"  # its own.
    assert trained.sim.fmt.screen_size == (16, 16)
    layers = trained.sim.fmt.screen_layers + trained.sim.fmt.minimap_layers
    session = PlaySession(trained.sim, layers=layers, width=128,
                          agent=evaluation.host_core(trained.core, trained.params),
                          agent_carry=trained.core.initial_carry(1), agent_name=trained.name)
    for _ in range(3):
        session.step()
    frame = session.frame()
    assert frame.status["mode"] == "watch" and frame.status["step"] == 3
    assert [f.name for f in frame.panels] == ["player_relative", "selected",
                                              "player_relative"]
    with pytest.raises(FileNotFoundError):
        trainer.trained_agent(str(tmp_path / "missing"))
