"""The flags that the commands share, defined from one table, and `TrainConfig` from them.

Each command asks for the flags it takes (`define`), with its own defaults where they
differ from `TrainConfig`'s; the training commands (train, sweep, table1) take them all
(`define_training`) plus `--preset` and `--run_dir`.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import sys
import tempfile

import jax
from absl import flags

from sc2jax.checks import check_not_a_file
from sc2jax.environment.engine.xla.compilation_cache import ENV, cache_dir
from sc2jax.environment.interface.map_names import MINI_GAMES
from sc2jax.experiments.training import data_parallel
from sc2jax.experiments.training.config import BACKENDS, TrainConfig, parse_names
from sc2jax.experiments.training.presets import PRESETS, get_preset
from sc2jax.networks.factory import NETWORKS

FLAGS = flags.FLAGS
_DEFAULTS = TrainConfig()

flags.DEFINE_string(
    "compilation_cache", str(cache_dir() or ""),
    "JAX's persistent compilation cache: compiled programs are written here and reused by "
    "later runs of the same programs, so their first steps skip compilation. '' turns it "
    f"off. The default follows ${ENV} (0: off; a folder), else ~/.cache/sc2jax/jax.")


def start_command() -> None:
    """What a command does first, once its flags are parsed: JAX's persistent compilation
    cache at --compilation_cache (unless ''; programs that took at least a second to
    compile are kept and reused), and no INFO line from JAX about the backends it looks
    for and does not find (TPU)."""
    logging.getLogger("jax._src.xla_bridge").setLevel(logging.WARNING)
    if FLAGS.compilation_cache:
        jax.config.update("jax_compilation_cache_dir", FLAGS.compilation_cache)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
    else:  # Off for `make` (`use_compilation_cache`) and child processes too.
        os.environ[ENV] = "0"

# flag name -> (TrainConfig field, absl definer, help).
_TABLE = {
    "map": ("map_name", flags.DEFINE_string,
            f"Mini-game: one of {sorted(MINI_GAMES)}, or a ladder map (with --backend=sc2, "
            "any map the game has)."),
    "backend": ("backend", flags.DEFINE_string,
                f"One of {list(BACKENDS)}: 'simulator' (embedded) or 'sc2' (StarCraft II, one "
                "game process per environment, from --sc2path)."),
    "bot": ("bot", flags.DEFINE_string, "A built-in AI opponent on a ladder map: "
            "race,difficulty[,build], e.g. terran,easy (the simulator's: terran at "
            "very_easy, easy, medium or hard)."),
    "score_index": ("score_index", flags.DEFINE_integer, "The reward (simulator): unset for "
                    "the map's default (the mini-games' score, the outcome on ladder maps), "
                    "-1 the outcome, -2 the Blizzard score, k >= 0 score_cumulative[k]."),
    "network": ("agent", flags.DEFINE_string, f"Network: one of {sorted(NETWORKS)} "
                "(raw_fullyconv plays PySC2's raw interface)."),
    "max_units": ("max_units", flags.DEFINE_integer,
                  "Rows of raw_units a raw network reads (raw_fullyconv)."),
    "screen_size": ("screen_size", flags.DEFINE_integer, "Feature-screen resolution (16..256)."),
    "minimap_size": ("minimap_size", flags.DEFINE_integer,
                     "Feature-minimap resolution (16..256)."),
    "screen_features": ("screen_features", flags.DEFINE_string,
                        "Comma-separated screen layers, or 'all'."),
    "minimap_features": ("minimap_features", flags.DEFINE_string,
                         "Comma-separated minimap layers, or 'all'."),
    "functions": ("functions", flags.DEFINE_string, "The agent's action set: comma-separated "
                  "PySC2 function names (RAW_FUNCTIONS' for a raw network), or 'all' (the "
                  "paper's setting)."),
    "step_mul": ("step_mul", flags.DEFINE_integer, "Game loops per agent step."),
    "num_envs": ("num_envs", flags.DEFINE_integer, "Environments stepped together."),
    "unroll_length": ("unroll_length", flags.DEFINE_integer, "K: agent steps per trajectory."),
    "total_steps": ("total_steps", flags.DEFINE_integer,
                    "Agent steps of the run, over all environments."),
    "learning_rate": ("learning_rate", flags.DEFINE_float,
                      "Initial learning rate (annealed linearly to half)."),
    "warmup_updates": ("warmup_updates", flags.DEFINE_integer,
                       "Updates over which the learning rate first rises from 0."),
    "discount": ("discount", flags.DEFINE_float, "γ."),
    "value_weight": ("value_weight", flags.DEFINE_float, "β."),
    "entropy_weight": ("entropy_weight", flags.DEFINE_float,
                       "η for the function id and each argument."),
    "rmsprop_decay": ("rmsprop_decay", flags.DEFINE_float, "RMSProp decay."),
    "rmsprop_epsilon": ("rmsprop_epsilon", flags.DEFINE_float, "RMSProp ε."),
    "non_point_rate_scale": (
        "non_point_rate_scale", flags.DEFINE_float, "Multiplies the learning rate of every "
        "parameter outside the spatial-argument heads (1: one rate, the paper's). With the "
        "zero background, spatial 2e-2 and the rest 1e-3 reached 20 on 5 of 6 MoveToBeacon "
        "seeds, one rate 5e-3 on 11 of 18. FullyConv LSTM needs it at such rates: at one rate "
        "of 5e-3 its ConvLSTM's output gate closed and it did not learn; with 0.1 it learns "
        "MoveToBeacon (docs/results.md)."),
    "reward_scale": ("reward_scale", flags.DEFINE_float,
                     "Multiplies the rewards the learner sees (logged scores stay the game's)."),
    "max_grad_norm": ("max_grad_norm", flags.DEFINE_float,
                      "Global gradient-norm clip (0: none)."),
    "off_policy_correction": ("off_policy_correction", flags.DEFINE_string,
                              "The policy gradient: 'none' (n-step A3C), 'vtrace', or 'ppo' "
                              "(clipped surrogate, GAE, several passes per batch)."),
    "ppo_epochs": ("ppo_epochs", flags.DEFINE_integer, "PPO: passes over each batch."),
    "ppo_minibatches": ("ppo_minibatches", flags.DEFINE_integer,
                        "PPO: gradient steps per pass, each on that share of the "
                        "environments."),
    "ppo_clip": ("ppo_clip", flags.DEFINE_float, "PPO: the ratio's clip ε."),
    "gae_lambda": ("gae_lambda", flags.DEFINE_float, "PPO: GAE's λ."),
    "compute_dtype": ("compute_dtype", flags.DEFINE_string,
                      "The network's convolutions and matmuls: 'float32' or 'bfloat16' "
                      "(parameters and optimiser stay float32)."),
    "actor_device": ("actor_device", flags.DEFINE_integer,
                     "Act on this local device beside the learner on device 0 (the split "
                     "loop: acting overlaps learning; use V-trace). Unset: one compiled "
                     "program acts, then learns."),
    "pipelined": ("pipelined", flags.DEFINE_bool,
                  "Act for the next batch while learning from the last, in one compiled "
                  "program (the policy one update behind; use V-trace or PPO)."),
    "seed": ("seed", flags.DEFINE_integer, "Random seed."),
    "updates_per_chunk": ("updates_per_chunk", flags.DEFINE_integer,
                          "Updates between log rows."),
    "checkpoint_interval_s": ("checkpoint_interval_s", flags.DEFINE_float,
                              "Seconds between checkpoints."),
    "eval_episodes": ("eval_episodes", flags.DEFINE_integer,
                      "Episodes of the final evaluation (0: none)."),
    "best_eval_interval": (
        "best_eval_interval", flags.DEFINE_integer, "Choose the best parameters (kept in "
        "run_dir/best) by evaluating the current ones every this many updates; 0: by the "
        "mean of the last 100 training episodes."),
    "best_eval_episodes": ("best_eval_episodes", flags.DEFINE_integer,
                           "Episodes of each of those evaluations."),
    "init_from": ("init_from", flags.DEFINE_string, "Start from the last parameters of this "
                  "run directory: an A3C run, or a replay run (train_replays), of the same "
                  "agent, resolutions and layers."),
    "sc2path": (None, flags.DEFINE_string, "The game's install (default $SC2PATH)."),
}
_NAMES = ("screen_features", "minimap_features", "functions", "bot")  # Lists in one string.
ALIASES = {"network": ("agent",), "screen_size": ("feature_screen_size",),
           "minimap_size": ("feature_minimap_size",)}
"""Other names a flag answers to: its old name (`--agent`: `--network` means the
architecture and `--agent` a policy, in `evaluate`) and PySC2's names."""


def _flag_default(field: str | None):
    """The flag's default: `TrainConfig`'s, with lists as one comma-separated string."""
    value = None if field is None else getattr(_DEFAULTS, field)
    if field in _NAMES and field != "bot":
        return "all" if value is None else ",".join(value)
    return value


def define(names, **defaults) -> dict[str, flags.FlagHolder]:
    """Defines the shared flags `names` (keys of the table), with `TrainConfig`'s defaults
    unless `defaults` names another; returns their holders by name."""
    unknown = set(defaults) - set(names)
    if unknown:
        raise ValueError(f"defaults for flags not defined here: {sorted(unknown)}; "
                         f"defined: {list(names)}")
    holders = {}
    for name in names:
        field, definer, help_text = _TABLE[name]
        default = defaults.get(name, _flag_default(field))
        holders[name] = definer(name, default, help_text)
        for alias in ALIASES.get(name, ()):
            flags.DEFINE_alias(alias, name)
    return holders


def define_training() -> None:
    """Defines every shared flag (each `TrainConfig` field, `--sc2path`), `--preset` and
    `--run_dir`."""
    define(_TABLE)
    flags.DEFINE_string("preset", None, "A named configuration, its fields overridden by the "
                        f"flags given: one of {sorted(PRESETS)} "
                        "(sc2jax.experiments.training.presets).")
    flags.DEFINE_string("run_dir", None, "The run's directory (default: a new temporary one). "
                        "An existing run there is resumed.")


def define_processes(coordinator: bool = True) -> None:
    """Defines --num_processes and --process_id (and with `coordinator`, --coordinator):
    the processes or hosts a command is split over."""
    if coordinator:
        flags.DEFINE_string(
            "coordinator", None, "host:port of process 0, for a run over several processes "
            "or hosts (jax.distributed). Once any of --coordinator, --num_processes and "
            "--process_id is given, every process joins, and those not given are read from "
            "the cluster's environment (SLURM, Open MPI) as jax.distributed reads them.")
    flags.DEFINE_integer("num_processes", None, "How many processes (or hosts) the command "
                         "is split over; every one runs the same command line.", lower_bound=1)
    flags.DEFINE_integer("process_id", None, "This process's number, 0 .. num_processes-1.",
                         lower_bound=0)


def join_processes() -> None:
    """Joins this process to the others of a run (`data_parallel.initialize`) when
    --coordinator, --num_processes or --process_id is given. Call it first, before any
    JAX work."""
    given = [FLAGS[name].value for name in ("coordinator", "num_processes", "process_id")]
    if any(value is not None for value in given):
        data_parallel.initialize(*given)


def sweep_part() -> tuple[int, int]:
    """(this process's number, the number of processes) a sweep is split over: the flags,
    else the cluster's environment (`data_parallel.cluster_process`).

    Raises:
      ValueError: for a process number outside [0, num_processes), or several processes
        without --run_dir (each would make its own temporary one).
    """
    part = data_parallel.cluster_process(FLAGS.process_id, FLAGS.num_processes)
    if part[1] > 1 and not FLAGS.run_dir:
        raise ValueError(f"a sweep over {part[1]} processes needs --run_dir, a directory "
                         f"every process sees")
    return part


def field_value(name: str):
    """The `TrainConfig` value of the shared flag `name` (lists parsed)."""
    field, value = _TABLE[name][0], FLAGS[name].value
    if field == "bot":
        bot = parse_names(value)
        # A difficulty may be a number.
        return None if bot is None else tuple(int(v) if v.isdigit() else v for v in bot)
    return parse_names(value) if field in _NAMES else value


def config_from_flags() -> TrainConfig:
    """The `TrainConfig` of `--preset` (default: `TrainConfig()`) with every training flag
    given on the command line put over it. Raises ValueError for a bad value."""
    base = get_preset(FLAGS.preset).config if FLAGS.preset else _DEFAULTS
    changes = {_TABLE[name][0]: field_value(name) for name in _TABLE
               if _TABLE[name][0] and (FLAGS[name].present or not FLAGS.preset)}
    check_not_a_file("--run_dir", FLAGS["run_dir"].value if "run_dir" in FLAGS else None)
    return dataclasses.replace(base, **changes)


def refuse(command: str, replaced: dict[str, str]) -> None:
    """Exits with an error naming the flags a command takes instead of the shared flags
    it replaces (`replaced`: flag -> its replacement), if any of them is given."""
    given = [name for name in replaced if FLAGS[name].present]
    if given:
        sys.exit(f"error: {command} takes {', '.join(replaced[n] for n in given)}, not "
                 f"{', '.join('--' + n for n in given)}")


def run_dir_or_temporary(config: TrainConfig) -> str:
    """--run_dir, or a new temporary directory named after the map."""
    return FLAGS.run_dir or tempfile.mkdtemp(prefix=f"sc2jax-{config.map_name}-")
