"""Replays played back by a game through the SC2 API (here sc2jax's server, which plays
its own replays back), written in the datasets' format: the game's observations, the
player's calls as labels, and the result as the value."""

import json
import pathlib
import shutil
import subprocess
import sys
import threading

import numpy as np
import pytest

from sc2jax.environment.interface import narrow
from sc2jax.environment.interface.dense import DenseAction, to_dense
from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.environment.sc2api import proto_actions, proto_observation
from sc2jax.environment.sc2api.controller import Controller
from sc2jax.environment.sc2api.protos import sc2api
from sc2jax.environment.server import Sc2ApiServer
from sc2jax.environment.server.install_layout import write_sc2path
from sc2jax.replay_sl.dataset import Settings, dataset_settings, read_shard, schema
from sc2jax.replay_sl.playback import VICTORY, interface_options, playback_replays

SETTINGS = Settings(screen_size=16, minimap_size=16)
REPLAYS = pathlib.Path(__file__).parents[3] / "shared" / "replays"


@pytest.fixture
def controller():
    server = Sc2ApiServer(port=0)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    controller = Controller.connect("127.0.0.1", server.port)
    yield controller
    controller.close()
    server.shutdown()


def _play_episode(controller):
    """A whole MoveToBeacon episode of a fixed pattern of calls: (the decoded
    observations, the calls, the result, the replay's bytes)."""
    controller.create_game(map_path="MoveToBeacon.SC2Map", random_seed=7)
    controller.join_game(interface_options(SETTINGS))
    fmt = ObservationFormat(16, 16)
    rng = np.random.default_rng(0)
    observations, calls = [], []
    while True:
        response = controller.observe()
        if response.player_result:
            break
        observations.append(proto_observation.decode(response, fmt, "MoveToBeacon"))
        kind = len(calls) % 4
        call = (FunctionCall(FUNCTIONS.select_army.id, [[0]]) if kind == 0 else
                FunctionCall(FUNCTIONS.Move_screen.id, [[0], rng.integers(16, size=2).tolist()])
                if kind == 1 else FunctionCall(FUNCTIONS.no_op.id, []))
        if kind < 2:
            controller.actions([proto_actions.to_proto(call)])
        calls.append(call)
        controller.step(SETTINGS.step_mul)
    result = response.player_result[0].result
    data = controller.save_replay()
    controller.leave()
    return observations, calls, result, data


def test_a_played_back_replay_gives_the_games_observations_and_calls(tmp_path, controller):
    observations, calls, result, data = _play_episode(controller)
    replay = tmp_path / "replays" / "beacon.SC2Replay"
    replay.parent.mkdir()
    replay.write_bytes(data)
    (tmp_path / "replays" / "broken.SC2Replay").write_bytes(b"MPQ\x1b not a replay")
    out = tmp_path / "data"
    paths = sorted(str(p) for p in replay.parent.iterdir())
    summary = playback_replays(paths, out, SETTINGS, controller, log=lambda _: None)
    assert [f["replay"] for f in summary["failed"]] == [paths[1]]
    assert "StarCraft II replay (MPQ)" in summary["failed"][0]["error"]
    (converted,) = summary["replays"]
    assert converted["records"] == len(calls) == 240  # 1,920 loops in steps of 8
    records = list(read_shard(converted["shard"], schema(dataset_settings(out))))
    for t, (record, obs, call) in enumerate(zip(records, observations, calls)):
        layers = narrow.unpack_observation(record, SCREEN_FEATURES, MINIMAP_FEATURES)
        for key in narrow.LAYER_KEYS:
            np.testing.assert_array_equal(layers[key], obs[key])
        np.testing.assert_array_equal(record["player"], obs["player"])
        assert sorted(np.flatnonzero(record["available_actions_mask"])) == sorted(
            obs["available_actions"])
        assert record["game_loop"] == 8 * t
        label = DenseAction(*(record[f"action_{n}"] for n in DenseAction._fields))
        expected = to_dense(call, ObservationFormat(16, 16).types)
        for got, want in zip(label, expected):
            np.testing.assert_array_equal(got, want)
        assert record["value"] == float(result == VICTORY)
    # Run again, it resumes: the shard is there.
    lines = []
    playback_replays(paths[:1], out, SETTINGS, controller, log=lines.append)
    assert lines == ["1/1 beacon.SC2Replay: already there"]


def test_a_replay_at_other_resolutions_is_skipped_with_the_reason(tmp_path, controller):
    *_, data = _play_episode(controller)
    replay = tmp_path / "beacon.SC2Replay"
    replay.write_bytes(data)
    summary = playback_replays([str(replay)], tmp_path / "data", Settings(32, 32), controller,
                               log=lambda _: None)
    (failed,) = summary["failed"]
    assert "recorded resolutions" in failed["error"]
    assert controller.status == sc2api.Status.Value("launched")
    assert not list((tmp_path / "data").rglob("*.array_record"))


@pytest.mark.slow
def test_the_command_launches_the_game_of_each_build(tmp_path, controller):
    *_, data = _play_episode(controller)
    replays = tmp_path / "replays"
    replays.mkdir()
    (replays / "beacon.SC2Replay").write_bytes(data)
    real = REPLAYS / "asus_rog/0001_KairosJunction.SC2Replay"  # build 75025
    if real.exists():
        shutil.copy(real, replays / "kairos.SC2Replay")
    root = write_sc2path(tmp_path / "StarCraftII")  # The simulator's server, a newer build.
    out = tmp_path / "data"
    done = subprocess.run(
        [sys.executable, "-m", "sc2jax.experiments.playback_replays", f"--replays={replays}",
         f"--output={out}", f"--sc2path={root}", "--screen_size=16", "--minimap_size=16"],
        capture_output=True, text=True, timeout=600)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr[-3000:]
    summary = json.loads((out / "conversion.json").read_text())
    assert [r["records"] for r in summary["replays"]] == [240]
    if real.exists():
        (failed,) = summary["failed"]
        assert "build 75025 is not installed" in failed["error"], failed
