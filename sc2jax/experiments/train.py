r"""Trains an agent on a mini-game of the embedded simulator (or on StarCraft II
itself), then evaluates it.

    python -m sc2jax.experiments.train --map=MoveToBeacon --agent=fullyconv \
        --total_steps=5000000 --run_dir=/tmp/runs/beacon
    python -m sc2jax.experiments.train --backend=sc2 --num_envs=8 ...   # the real game
    python -m sc2jax.experiments.train --backend=sc2 --map=Simple64 --bot=terran,easy

Defaults follow the paper: 64x64 feature layers, step_mul 8, K = 40, entropy 1e-3,
RMSProp with the learning rate annealed linearly to half. The run directory gets the
resolved config, Orbax checkpoints, metrics.csv, TensorBoard events, every training
episode's score, a learning-curve PNG and the final evaluation (eval.json). Running
the same command again resumes from the last checkpoint.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile

from absl import app, flags

from sc2jax.environment import MAPS
from sc2jax.experiments.config import BACKENDS, TrainConfig, parse_names
from sc2jax.experiments.paper import paper_rows
from sc2jax.experiments.trainer import train
from sc2jax.networks.factory import NETWORKS

_DEFAULTS = TrainConfig()

_RUN_DIR = flags.DEFINE_string("run_dir", None, "The run's directory (default: a new "
                               "temporary one). An existing run there is resumed.")
_MAP = flags.DEFINE_string("map", _DEFAULTS.map_name, f"Mini-game: one of {sorted(MAPS)} "
                           "(with --backend=sc2, any map the game has).")
_BACKEND = flags.DEFINE_enum("backend", _DEFAULTS.backend, list(BACKENDS),
                             "'simulator' (embedded) or 'sc2' (StarCraft II, one game process "
                             "per environment, from --sc2path).")
_SC2PATH = flags.DEFINE_string("sc2path", None, "The game's install (default $SC2PATH).")
_BOT = flags.DEFINE_string("bot", None, "A built-in AI opponent on the real game: "
                           "race,difficulty[,build], e.g. terran,easy.")
_AGENT = flags.DEFINE_string("agent", _DEFAULTS.agent, f"Network: one of {sorted(NETWORKS)}.")
_SCREEN = flags.DEFINE_integer("screen_size", _DEFAULTS.screen_size,
                               "Feature-screen resolution (16..256).")
_MINIMAP = flags.DEFINE_integer("minimap_size", _DEFAULTS.minimap_size,
                                "Feature-minimap resolution (16..256).")
_SCREEN_FEATURES = flags.DEFINE_string("screen_features", "all",
                                       "Comma-separated screen layers, or 'all'.")
_MINIMAP_FEATURES = flags.DEFINE_string("minimap_features", "all",
                                        "Comma-separated minimap layers, or 'all'.")
_FUNCTIONS = flags.DEFINE_string("functions", "all", "The agent's action set: comma-separated "
                                 "PySC2 function names, or 'all' (the paper's setting).")
_STEP_MUL = flags.DEFINE_integer("step_mul", _DEFAULTS.step_mul, "Game loops per agent step.")
_NUM_ENVS = flags.DEFINE_integer("num_envs", _DEFAULTS.num_envs,
                                 "Environments stepped together.")
_UNROLL = flags.DEFINE_integer("unroll_length", _DEFAULTS.unroll_length,
                               "K: agent steps per trajectory.")
_TOTAL = flags.DEFINE_integer("total_steps", _DEFAULTS.total_steps,
                              "Agent steps of the run, over all environments.")
_LR = flags.DEFINE_float("learning_rate", _DEFAULTS.learning_rate,
                         "Initial learning rate (annealed linearly to half).")
_WARMUP = flags.DEFINE_integer("warmup_updates", _DEFAULTS.warmup_updates,
                               "Updates over which the learning rate first rises from 0.")
_DISCOUNT = flags.DEFINE_float("discount", _DEFAULTS.discount, "γ.")
_VALUE = flags.DEFINE_float("value_weight", _DEFAULTS.value_weight, "β.")
_ENTROPY = flags.DEFINE_float("entropy_weight", _DEFAULTS.entropy_weight,
                              "η for the function id and each argument.")
_DECAY = flags.DEFINE_float("rmsprop_decay", _DEFAULTS.rmsprop_decay, "RMSProp decay.")
_EPSILON = flags.DEFINE_float("rmsprop_epsilon", _DEFAULTS.rmsprop_epsilon, "RMSProp ε.")
_NON_POINT_SCALE = flags.DEFINE_float(
    "non_point_rate_scale", _DEFAULTS.non_point_rate_scale, "Multiplies the learning rate of "
    "every parameter outside the spatial-argument heads (1: one rate, the paper's). With the "
    "zero background, spatial 2e-2 and the rest 1e-3 reached 20 on 5 of 6 MoveToBeacon "
    "seeds, one rate 5e-3 on 11 of 18. FullyConv LSTM needs it at such rates: at one rate "
    "of 5e-3 its ConvLSTM's output gate closed and it did not learn; with 0.1 it learns "
    "MoveToBeacon (docs/results.md).")
_CLIP = flags.DEFINE_float("max_grad_norm", _DEFAULTS.max_grad_norm,
                           "Global gradient-norm clip (0: none).")
_CORRECTION = flags.DEFINE_string("off_policy_correction", _DEFAULTS.off_policy_correction,
                                  "'none' (n-step A3C) or 'vtrace'.")
_SEED = flags.DEFINE_integer("seed", _DEFAULTS.seed, "Random seed.")
_CHUNK = flags.DEFINE_integer("updates_per_chunk", _DEFAULTS.updates_per_chunk,
                              "Updates between log rows.")
_CHECKPOINT = flags.DEFINE_float("checkpoint_interval_s", _DEFAULTS.checkpoint_interval_s,
                                 "Seconds between checkpoints.")
_EVAL = flags.DEFINE_integer("eval_episodes", _DEFAULTS.eval_episodes,
                             "Episodes of the final evaluation (0: none).")
_BEST_INTERVAL = flags.DEFINE_integer(
    "best_eval_interval", _DEFAULTS.best_eval_interval, "Choose the best parameters (kept "
    "in run_dir/best) by evaluating the current ones every this many updates; 0: by the "
    "mean of the last 100 training episodes.")
_BEST_EPISODES = flags.DEFINE_integer("best_eval_episodes", _DEFAULTS.best_eval_episodes,
                                      "Episodes of each of those evaluations.")


def config_from_flags() -> TrainConfig:
    """The `TrainConfig` of the flags (ValueError for a bad value)."""
    bot = parse_names(_BOT.value)
    if bot is not None:  # A difficulty may be a number.
        bot = tuple(int(v) if v.isdigit() else v for v in bot)
    return TrainConfig(
        map_name=_MAP.value, backend=_BACKEND.value, bot=bot, agent=_AGENT.value,
        screen_size=_SCREEN.value, minimap_size=_MINIMAP.value,
        screen_features=parse_names(_SCREEN_FEATURES.value),
        minimap_features=parse_names(_MINIMAP_FEATURES.value),
        functions=parse_names(_FUNCTIONS.value), step_mul=_STEP_MUL.value,
        num_envs=_NUM_ENVS.value, unroll_length=_UNROLL.value, total_steps=_TOTAL.value,
        learning_rate=_LR.value, warmup_updates=_WARMUP.value, discount=_DISCOUNT.value,
        value_weight=_VALUE.value, entropy_weight=_ENTROPY.value, rmsprop_decay=_DECAY.value,
        rmsprop_epsilon=_EPSILON.value, non_point_rate_scale=_NON_POINT_SCALE.value,
        max_grad_norm=_CLIP.value,
        off_policy_correction=_CORRECTION.value, seed=_SEED.value,
        updates_per_chunk=_CHUNK.value, checkpoint_interval_s=_CHECKPOINT.value,
        eval_episodes=_EVAL.value, best_eval_interval=_BEST_INTERVAL.value,
        best_eval_episodes=_BEST_EPISODES.value)


def run_dir_or_temporary(config: TrainConfig) -> str:
    """--run_dir, or a new temporary directory named after the map."""
    return _RUN_DIR.value or tempfile.mkdtemp(prefix=f"sc2jax-{config.map_name}-")


def main(argv) -> None:
    del argv
    try:
        config = config_from_flags()
    except ValueError as error:
        sys.exit(f"error: {error}")
    run_dir = run_dir_or_temporary(config)
    changed = {k: v for k, v in dataclasses.asdict(config).items()
               if getattr(_DEFAULTS, k) != v}
    print(f"Run directory: {os.path.abspath(run_dir)}\nSettings changed from the paper's "
          f"defaults: {changed or 'none'}", flush=True)
    try:
        result = train(config, run_dir, sc2path=_SC2PATH.value)
    except ValueError as error:
        sys.exit(f"error: {error}")
    print(f"\nTrained for {result.seconds / 60:.1f} min; "
          f"{result.episode_scores.size} training episodes")
    if result.evaluation:
        s = result.evaluation
        print(f"{config.map_name}, trained {config.agent}: mean {s['mean']:.2f} ± "
              f"{s['std']:.2f} (std), max {s['max']:g}, over {s['episodes']} episodes")
        if result.best_evaluation:
            b = result.best_evaluation
            print(f"  its best parameters (at {b['env_steps']} agent steps, "
                  f"{b['chosen_by']} score {b['score']:.2f}): mean {b['mean']:.2f} ± "
                  f"{b['std']:.2f} (std), max {b['max']:g}")
        if config.map_name in MAPS:
            print("The paper's Table 1:")
            print(paper_rows(config.map_name))
    print(f"Results in {os.path.abspath(run_dir)}")


if __name__ == "__main__":
    app.run(main)
