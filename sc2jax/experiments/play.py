r"""Plays or watches a mini-game in the browser: the human view, the minimap, the feature
layers, the score and the available functions (like PySC2's `pysc2.bin.play`).

    python -m sc2jax.experiments.play --map=MoveToBeacon
    python -m sc2jax.experiments.play --map=DefeatRoaches --agent=scripted --speed=8
    python -m sc2jax.experiments.play --agent=/tmp/runs/beacon
    python -m sc2jax.experiments.play --episode=/tmp/episodes/episode_000.npz
    python -m sc2jax.experiments.play --replay=GAME.SC2Replay --player=2

It starts a web server, by default on 127.0.0.1 (this machine only: from elsewhere, use
SSH port forwarding, `ssh -L 8000:127.0.0.1:8000 host`), and prints its address.

- `--agent=human` (the default): a person plays with the mouse and keys, as in the game;
  every input becomes a PySC2 call, checked as an agent's is. Each finished episode is
  saved to `--save` (if given) as an episode file.
- `--agent=random|scripted|RUN_DIR`: watch an agent (a trained A3C run plays its own map
  and format; a replay run plays `--map`).
- `--episode=FILE`: play back an episode recorded by `evaluate --record` or by `play
  --save`, with a timeline to scrub.
- `--replay=FILE --player=ID`: a human replay decoded without the game, as the player saw
  it (`viewer.replays`: the whole map at minimap level, the dataset's feature layers and
  the player's PySC2 calls), with a timeline.
"""

from __future__ import annotations

import glob
import os
import sys
import time

from absl import app, flags

from sc2jax.environment import MAPS, make
from sc2jax.environment.agents import required_format
from sc2jax.environment.episodes import EpisodeError, load_episode, save_episode
from sc2jax.experiments.training import evaluation, trainer
from sc2jax.experiments.training import flags as training_flags
from sc2jax.experiments.viewer.replays import ReplayPlayback
from sc2jax.experiments.viewer.server import MAX_SPEED, ViewerServer
from sc2jax.experiments.viewer.session import Playback, PlaySession
from sc2jax.replay_sl import ReplayError

_MAP, _SCREEN, _MINIMAP, _STEP_MUL, _SEED = training_flags.define(
    ("map", "screen_size", "minimap_size", "step_mul", "seed")).values()
_AGENT = flags.DEFINE_string("agent", "human", "Who plays: human, random, scripted, or a "
                             "training run's directory.")
_EPISODE = flags.DEFINE_string("episode", None, "Play back this episode file instead.")
_REPLAY = flags.DEFINE_string("replay", None, "Show this StarCraft II replay instead.")
_PLAYER = flags.DEFINE_integer("player", 1, "With --replay: whose view (1 or 2).")
_FULL_INFORMATION = flags.DEFINE_bool("full_information", False, "With --replay: show every "
                                      "enemy unit, not only those in sight.")
_HOST = flags.DEFINE_string("host", "127.0.0.1", "Address to serve on (0.0.0.0 opens it to "
                            "the network).")
_PORT = flags.DEFINE_integer("port", 8000, "Port to serve on (0: any free one).")
_SPEED = flags.DEFINE_float("speed", 4.0, "Agent steps per second.")
_PAUSED = flags.DEFINE_bool("paused", False, "Start paused.")
_WIDTH = flags.DEFINE_integer("width", 384, "The human view's width in pixels.")
_SAVE = flags.DEFINE_string("save", None, "Save each finished episode to this directory "
                            "(numbered after the episodes already there).")
_TEMPERATURE = flags.DEFINE_float("temperature", 1.0, "Softmax temperature of a trained "
                                  "network's actions.")
_SECONDS = flags.DEFINE_float("seconds", None, "Stop after this many seconds (default: "
                              "run until interrupted).")

flags.adopt_module_key_flags(training_flags)

AGENTS = ("human", *evaluation.AGENTS)


def check_flags() -> None:
    """Raises ValueError for bad flag values, before anything is compiled."""
    if _EPISODE.value and _REPLAY.value:
        raise ValueError("give --episode or --replay, not both")
    if _REPLAY.value and not os.path.isfile(_REPLAY.value):
        raise ValueError(f"--replay={_REPLAY.value!r} is not a file")
    recorded = _EPISODE.value or _REPLAY.value
    if not recorded and _MAP.value not in MAPS:
        raise ValueError(f"--map={_MAP.value!r} is unknown; allowed: {sorted(MAPS)}")
    if (not recorded and _AGENT.value not in AGENTS
            and not os.path.isdir(_AGENT.value)):
        raise ValueError(f"--agent={_AGENT.value!r} is neither one of {list(AGENTS)} nor a "
                         f"training run's directory")
    if not 0 < _SPEED.value <= MAX_SPEED:
        raise ValueError(f"--speed must be in (0, {MAX_SPEED}], got {_SPEED.value}")
    if not 0 <= _PORT.value <= 65535:
        raise ValueError(f"--port must be in [0, 65535], got {_PORT.value}")
    if not 64 <= _WIDTH.value <= 2048:
        raise ValueError(f"--width must be in [64, 2048], got {_WIDTH.value}")


def _source() -> PlaySession | Playback | ReplayPlayback:
    """The game or playback the flags ask for."""
    if _REPLAY.value:
        return ReplayPlayback(_REPLAY.value, _PLAYER.value, _WIDTH.value,
                              _FULL_INFORMATION.value)
    if _EPISODE.value:
        return Playback(load_episode(_EPISODE.value), width=_WIDTH.value)
    agent, name, carry = None, None, None
    if _AGENT.value in AGENTS:
        extra = required_format(_MAP.value) if _AGENT.value == "scripted" else {}
        sim = make(_MAP.value, _SCREEN.value, _MINIMAP.value, _STEP_MUL.value, **extra).simulator
        if _AGENT.value != "human":
            name = _AGENT.value
            agent = evaluation.host_policy(evaluation.make_policy(name, _MAP.value, sim.fmt))
    else:
        trained = trainer.trained_agent(_AGENT.value, _MAP.value, _TEMPERATURE.value)
        sim, name = trained.sim, trained.name
        agent = evaluation.host_core(trained.core, trained.params)
        carry = trained.core.initial_carry(1)
    layers = sim.fmt.screen_layers + sim.fmt.minimap_layers
    return PlaySession(sim, _SEED.value, layers, _WIDTH.value, agent, carry, name)


def main(argv) -> None:
    del argv
    training_flags.start_command()
    try:
        check_flags()
        server = ViewerServer(_HOST.value, _PORT.value, _SPEED.value, _PAUSED.value)
    except ValueError as error:
        sys.exit(f"error: {error}")
    try:
        source = _source()
    except (ValueError, FileNotFoundError, EpisodeError, ReplayError) as error:
        server.close()
        sys.exit(f"error: {error}")
    print("Compiling the first step's pictures ...", flush=True)
    source.frame()
    server.start(source)
    print(f"The viewer is at {server.address} (Ctrl+C stops it)", flush=True)
    saved = 0
    # Numbered after the episodes already in --save, which are never overwritten.
    first = len(glob.glob(os.path.join(_SAVE.value, "episode_*.npz"))) if _SAVE.value else 0
    deadline = None if _SECONDS.value is None else time.monotonic() + _SECONDS.value
    try:
        while deadline is None or time.monotonic() < deadline:
            time.sleep(0.5)
            if _SAVE.value and isinstance(source, PlaySession):
                for episode in source.episodes[saved:]:
                    path = os.path.join(_SAVE.value, f"episode_{first + saved:03d}.npz")
                    while os.path.exists(path):  # A gap in the numbers.
                        first += 1
                        path = os.path.join(_SAVE.value, f"episode_{first + saved:03d}.npz")
                    save_episode(path, episode)
                    saved += 1
                    print(f"Saved {path} (score {episode.score:g})", flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()


if __name__ == "__main__":
    app.run(main)
