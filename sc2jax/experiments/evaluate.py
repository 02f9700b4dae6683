r"""Evaluates an agent on a mini-game of the embedded simulator, or on StarCraft II.

    python -m sc2jax.experiments.evaluate --map=MoveToBeacon --agent=scripted \
        --episodes=100 --output=/tmp/eval.json
    python -m sc2jax.experiments.evaluate --run_dir=/tmp/runs/beacon --episodes=100
    python -m sc2jax.experiments.evaluate --run_dir=/tmp/runs/beacon --backend=sc2 \
        --num_envs=4
    python -m sc2jax.experiments.evaluate --map=DefeatRoaches --agent=scripted \
        --episodes=4 --video=/tmp/videos --record=/tmp/episodes

The agent is random, scripted, or (with `--run_dir`) a trained network restored from
a training run's last checkpoint (or `--checkpoint_step`): an A3C run plays its own map
and observation format; a replay run (`train_replays`) plays `--map` with every
function, at its dataset's resolutions and step_mul. With `--backend=sc2` the episodes
are played in `--num_envs` game processes launched from `--sc2path`, each playing its
share of the episodes in turn.

Prints the mean, std and max episode score beside the paper's Table 1, and with
`--output` writes them as JSON: `episodes`, `mean`, `std`, `max`, `min`, `scores` (every
episode's score) and the resolved `config` (for a trained run, its own map, agent,
sizes, action set and the agent steps it was trained for).

With `--video=DIR` it then plays `--video_episodes` more episodes with `--seed` and writes
a video of each (the human view beside feature layers, captioned with the score, the
step and the action), and a grid of them; with `--record=DIR` it saves those episodes
as files that replay exactly (`sc2jax.environment.episodes`).
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time

from absl import app, flags

from sc2jax.atomic import write_json_atomic
from sc2jax.environment import MAPS, make
from sc2jax.environment.agents import required_format
from sc2jax.environment.episodes import save_episode
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.environment.sc2api.game_env import GameEnvBatch
from sc2jax.experiments.reporting.paper import paper_rows
from sc2jax.experiments.training import evaluation, pretrained, trainer
from sc2jax.experiments.training import flags as training_flags
from sc2jax.experiments.training.actor import actor_core
from sc2jax.experiments.training.config import BACKENDS
from sc2jax.experiments.viewer import frames, video

_MAP, _BACKEND, _SC2PATH, _NUM_ENVS, _SCREEN, _MINIMAP, _STEP_MUL, _SEED = training_flags.define(
    ("map", "backend", "sc2path", "num_envs", "screen_size", "minimap_size", "step_mul", "seed"),
    num_envs=64).values()
_AGENT = flags.DEFINE_string("agent", "random", f"Agent: one of {list(evaluation.AGENTS)}.")
_EPISODES = flags.DEFINE_integer("episodes", 100, "Episodes to run.")
flags.DEFINE_alias("max_episodes", "episodes")  # PySC2's name (pysc2.bin.agent).
_OUTPUT = flags.DEFINE_string("output", None, "Write the results as JSON to this file.")
_RUN_DIR = flags.DEFINE_string("run_dir", None, "Evaluate the network trained in this run "
                               "directory (--agent is ignored): an A3C run on its own map "
                               "and format, or a replay run (train_replays) on --map with "
                               "its dataset's resolutions and step_mul.")
_STEP = flags.DEFINE_integer("checkpoint_step", None, "The run's checkpoint (default: last).")
_BEST = flags.DEFINE_bool("best", False, "Evaluate the run's best parameters (RUN_DIR/best: "
                          "those of its best recent training score, or of its best "
                          "periodic evaluation) instead.")
_TEMPERATURE = flags.DEFINE_float("temperature", 1.0, "Softmax temperature of a trained "
                                  "network's actions.")
_VIDEO = flags.DEFINE_string("video", None, "Write videos of the first --video_episodes "
                             "episodes to this directory: one per episode (the human view "
                             "beside --video_layers, with the score, step and action), and "
                             "a grid of them all.")
_RECORD = flags.DEFINE_string("record", None, "Save the first --video_episodes episodes to "
                              "this directory as episode files (map, seed and actions; "
                              "`python -m sc2jax.experiments.play --episode=FILE` shows one).")
_VIDEO_EPISODES = flags.DEFINE_integer("video_episodes", 4, "Episodes for --video and "
                                       "--record, played with --seed.")
_VIDEO_FORMAT = flags.DEFINE_enum("video_format", "gif", list(video.FORMATS),
                                  "gif, or mp4 (needs pip install 'sc2jax[video]').")
_VIDEO_LAYERS = flags.DEFINE_list("video_layers", list(frames.DEFAULT_LAYERS),
                                  "Feature layers shown beside the human view.")
_VIDEO_WIDTH = flags.DEFINE_integer("video_width", 384, "The human view's width in pixels.")
_VIDEO_FPS = flags.DEFINE_float("video_fps", 8.0, "Video frames (agent steps) per second.")


def check_flags() -> None:
    """Raises ValueError for bad flag values, before anything is compiled."""
    if _MAP.value not in MAPS and (_BACKEND.value != "sc2" or not _MAP.value):
        raise ValueError(f"--map={_MAP.value!r} is unknown; allowed: {sorted(MAPS)} (or any "
                         f"map of the game with --backend=sc2)")
    if _BACKEND.value not in BACKENDS:
        raise ValueError(f"--backend={_BACKEND.value!r} is unknown; allowed: {list(BACKENDS)}")
    if _AGENT.value not in evaluation.AGENTS:
        raise ValueError(f"--agent={_AGENT.value!r} is unknown; allowed: "
                         f"{list(evaluation.AGENTS)}")
    for flag in (_EPISODES, _NUM_ENVS, _STEP_MUL):
        if flag.value < 1:
            raise ValueError(f"--{flag.name} must be >= 1, got {flag.value}")
    if _BEST.value and (not _RUN_DIR.value or _STEP.value is not None
                        or pretrained.is_replay_run(_RUN_DIR.value)):
        raise ValueError("--best evaluates an A3C run's best parameters: it needs --run_dir "
                         "of such a run and takes no --checkpoint_step")
    if not _TEMPERATURE.value > 0:
        raise ValueError(f"--temperature must be > 0, got {_TEMPERATURE.value}")
    ObservationFormat(screen_size=_SCREEN.value, minimap_size=_MINIMAP.value)  # The sizes.
    if _VIDEO.value or _RECORD.value:
        if _BACKEND.value != "simulator":
            raise ValueError("--video and --record replay the simulator's episodes: they need "
                             "--backend=simulator")
        if _VIDEO_EPISODES.value < 1:
            raise ValueError(f"--video_episodes must be >= 1, got {_VIDEO_EPISODES.value}")
        if not 8 <= _VIDEO_WIDTH.value <= 4096:
            raise ValueError(f"--video_width must be in [8, 4096], got {_VIDEO_WIDTH.value}")
        if not _VIDEO_FPS.value > 0:
            raise ValueError(f"--video_fps must be > 0, got {_VIDEO_FPS.value}")
        frames.parse_layers(_VIDEO_LAYERS.value)
        if _VIDEO.value:
            video.check_format(_VIDEO_FORMAT.value)

flags.adopt_module_key_flags(training_flags)


def main(argv) -> None:
    del argv
    training_flags.start_command()
    try:
        check_flags()
    except ValueError as error:
        sys.exit(f"error: {error}")
    start = time.time()
    on_game = _BACKEND.value == "sc2"
    if _RUN_DIR.value and on_game:
        if pretrained.is_replay_run(_RUN_DIR.value):
            sys.exit("error: a replay run is evaluated on the simulator's mini-games only "
                     "(--backend=simulator)")
        try:
            trained, params, meta = trainer.load_run(_RUN_DIR.value, _STEP.value, _BEST.value)
        except (FileNotFoundError, ValueError) as error:
            sys.exit(f"error: {error}")
        config, agent_name = trained.config, trained.config.agent
        # What was evaluated: the run's own map and format, not the flags' defaults.
        resolved, restored = trainer.describe_run(config, meta, _RUN_DIR.value)
        core = actor_core(trained.network, _TEMPERATURE.value, config.functions)
        print(restored)
        games = trainer.launch_games(
            dataclasses.replace(config, backend="sc2", num_envs=_NUM_ENVS.value,
                                seed=_SEED.value), _SC2PATH.value)
        act = evaluation.host_core(core, params)
        carry = core.initial_carry(_NUM_ENVS.value)
        map_name = config.map_name
    elif _RUN_DIR.value:
        # An A3C run plays its own map and format, a replay run --map at its dataset's.
        try:
            trained = trainer.trained_agent(_RUN_DIR.value, _MAP.value, _TEMPERATURE.value,
                                            _STEP.value, _BEST.value)
        except (FileNotFoundError, ValueError) as error:
            sys.exit(f"error: {error}")
        print(trained.restored)
        sim, agent_name, map_name = trained.sim, trained.name, trained.sim.map_name
        resolved = trained.settings
        acting = (trained.core, trained.params)

        def run(on_batch):
            return evaluation.run_core_episodes(sim, *acting, _EPISODES.value,
                                                _NUM_ENVS.value, _SEED.value, on_batch)
    else:
        extra = required_format(_MAP.value) if _AGENT.value == "scripted" else {}
        sizes = dict(screen_size=_SCREEN.value, minimap_size=_MINIMAP.value,
                     step_mul=_STEP_MUL.value, **extra)
        agent_name, map_name = _AGENT.value, _MAP.value
        resolved = {}
        if on_game:
            games = GameEnvBatch([make(map_name, seed=_SEED.value + i, backend="sc2",
                                       sc2path=_SC2PATH.value, **sizes)
                                  for i in range(_NUM_ENVS.value)])
            act = evaluation.host_policy(
                evaluation.make_policy(agent_name, map_name, games.fmt))
            carry = None
        else:
            sim = make(map_name, **sizes).simulator
            policy = evaluation.make_policy(agent_name, map_name, sim.fmt)
            acting = (evaluation.policy_core(policy), None)

            def run(on_batch):
                return evaluation.run_episodes(sim, policy, _EPISODES.value,
                                               _NUM_ENVS.value, _SEED.value, on_batch)
    if on_game:
        def run(on_batch):
            try:
                return evaluation.run_host_episodes(games, act, carry, _EPISODES.value,
                                                    _SEED.value, on_batch)
            finally:
                games.close()

    def progress(stats: evaluation.EpisodeStats) -> None:
        s = stats.summary
        print(f"  {s['episodes']:>5} episodes  mean {s['mean']:8.2f}  max {s['max']:7.1f}  "
              f"({time.time() - start:.0f} s)", flush=True)

    print(f"Evaluating the {agent_name} agent on {map_name} for {_EPISODES.value} "
          f"episodes ({min(_NUM_ENVS.value, _EPISODES.value)} environments at a time; "
          f"the first batch compiles)", flush=True)
    stats = run(progress)
    s = stats.summary
    print(f"\n{map_name}, {agent_name} agent: mean {s['mean']:.2f} ± {s['std']:.2f} (std), "
          f"max {s['max']:g}, over {s['episodes']} episodes "
          f"[{time.time() - start:.0f} s]")
    if map_name in MAPS:
        print("The paper's Table 1:")
        print(paper_rows(map_name))
    if _OUTPUT.value:
        flag_values = {flag.name: flag.value for flag in (
            _MAP, _BACKEND, _AGENT, _EPISODES, _NUM_ENVS, _SCREEN, _MINIMAP, _STEP_MUL,
            _SEED, _RUN_DIR, _STEP, _BEST, _TEMPERATURE)}
        write_json_atomic(_OUTPUT.value, {**s, "scores": stats.scores.tolist(),
                                          "steps": stats.steps.tolist(),
                                          "config": {**flag_values, **resolved}})
        print(f"Wrote {_OUTPUT.value}")
    if _VIDEO.value or _RECORD.value:
        _write_episodes(sim, *acting, agent_name)


def _write_episodes(sim, core, params, agent_name: str) -> None:
    """Plays --video_episodes episodes and writes them (--record) and their videos
    (--video)."""
    count = _VIDEO_EPISODES.value
    start = time.time()
    episodes = evaluation.record_episodes(sim, core, params, count, _SEED.value, agent_name)
    print(f"Played {count} episodes to record (scores "
          f"{[round(e.score, 2) for e in episodes]}) [{time.time() - start:.0f} s]")
    if _RECORD.value:
        for i, episode in enumerate(episodes):
            save_episode(os.path.join(_RECORD.value, f"episode_{i:03d}.npz"), episode)
        print(f"Saved {count} episodes to {_RECORD.value}")
    if not _VIDEO.value:
        return
    layers = frames.parse_layers(_VIDEO_LAYERS.value)
    ext = _VIDEO_FORMAT.value
    drawn = []
    for i, episode in enumerate(episodes):
        drawn.append(frames.episode_pictures(episode, _VIDEO_WIDTH.value, layers))
        path = os.path.join(_VIDEO.value, f"episode_{i:03d}.{ext}")
        video.write_video(path, frames.episode_frames(episode, drawn[-1], layers),
                          _VIDEO_FPS.value)
        print(f"Wrote {path} [{time.time() - start:.0f} s]")
    if count > 1:
        path = os.path.join(_VIDEO.value, f"grid.{ext}")
        video.write_video(path, frames.batch_frames(drawn), _VIDEO_FPS.value)
        print(f"Wrote {path} [{time.time() - start:.0f} s]")


if __name__ == "__main__":
    app.run(main)
