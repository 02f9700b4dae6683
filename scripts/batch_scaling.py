r"""Learning per agent step as the batch grows, and A3C against PPO, at equal agent steps.

    # On a GPU: the issue's three maps at the paper's inputs, 16 to 1,024 environments.
    python scripts/batch_scaling.py --run_dir=runs/batch --num_envs_list=16,256,1024 \
        --total_steps=20000000
    # On a CPU: MoveToBeacon at the quick start's scale (docs/results.md has the numbers).
    python scripts/batch_scaling.py --run_dir=/tmp/batch --preset=beacon_quickstart \
        --maps=MoveToBeacon --num_envs_list=16,64,256 --total_steps=200000 --seeds=0,1

Every (map, algorithm, environment count, seed) is one `train` run in
RUN_DIR/MAP/ALGORITHM_ENVSenvs_kK_seedS: running the script again resumes the unfinished
ones and skips the finished. The first environment count is the reference, at K =
--unroll_length and --learning_rate. By default K stays fixed, so the batch grows with
the E environments, and the rate is --learning_rate x (E / first)^p, with p = 1/2 for
--rate_scaling=sqrt (the square-root rule for adaptive optimisers, as in Hoffer et al.
2017 and Stooke & Abbeel 2018), 1 for linear and 0 for none. With --hold_batch, K
shrinks instead (K x first / E, at least 1): the batch, the rate and the updates per
agent step stay the reference's, and only the parallelism grows. PPO runs use
--ppo_rate_scale times the rate.

Each run's row: the mean score of its training episodes over the whole run (the area
under the learning curve per agent step: what "learning per agent step" compares), over
the run's last fifth, and the evaluation of its final parameters. RUN_DIR/comparison.md
gets the table that is printed, each setting's mean over its seeds first.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys

import numpy as np
from absl import app, flags

from sc2jax.atomic import atomic_write
from sc2jax.checks import non_negative_ints, positive_ints
from sc2jax.experiments.reporting.metrics_log import read_csv
from sc2jax.experiments.sweeps.tables import parse_maps
from sc2jax.experiments.training import flags as training_flags
from sc2jax.experiments.training.trainer import train

training_flags.define_training()
_MAPS = flags.DEFINE_string("maps", "MoveToBeacon,CollectMineralShards,"
                            "DefeatZerglingsAndBanelings",
                            "Comma-separated mini-games, or 'all'.")
_NUM_ENVS = flags.DEFINE_list("num_envs_list", ["16", "256", "1024"],
                                "Environment counts; the first is the reference.")
_SCALING = flags.DEFINE_enum("rate_scaling", "sqrt", ["sqrt", "linear", "none"],
                             "How the learning rate grows with the environment count.")
_ALGORITHMS = flags.DEFINE_list("algorithms", ["none", "ppo"],
                                  "off_policy_correction values: none (A3C), vtrace, ppo.")
_HOLD_BATCH = flags.DEFINE_bool("hold_batch", False,
                                 "Shrink K as the environments grow, holding the batch.")
_PPO_RATE = flags.DEFINE_float("ppo_rate_scale", 1.0, "Multiplies PPO runs' learning rate.")
_SEEDS = flags.DEFINE_list("seeds", ["0", "1", "2"], "Seeds of every setting.")
flags.adopt_module_key_flags(training_flags)
FLAGS = flags.FLAGS

_POWER = {"sqrt": 0.5, "linear": 1.0, "none": 0.0}


def settings(config, maps, num_envs, algorithms, seeds, scaling: str, ppo_rate: float,
             hold_batch: bool = False):
    """(name, config) of every run: maps x algorithms x environment counts x seeds."""
    runs = []
    for map_name in maps:
        for algorithm in algorithms:
            for envs in num_envs:
                if hold_batch:
                    k = max(1, config.unroll_length * num_envs[0] // envs)
                    rate = config.learning_rate
                else:
                    k = config.unroll_length
                    rate = config.learning_rate * (envs / num_envs[0]) ** _POWER[scaling]
                rate *= ppo_rate if algorithm == "ppo" else 1.0
                for seed in seeds:
                    runs.append((f"{map_name}/{algorithm}_{envs}envs_k{k}_seed{seed}",
                                 dataclasses.replace(
                                     config, map_name=map_name, num_envs=envs,
                                     unroll_length=k, learning_rate=rate,
                                     off_policy_correction=algorithm, seed=seed)))
    return runs


def row(config, run_dir: str) -> dict:
    """A finished run's scores: training episodes over the run and its last fifth, and
    the final evaluation."""
    episodes = read_csv(os.path.join(run_dir, "episodes.csv"))
    steps, scores = np.asarray(episodes["step"]), np.asarray(episodes["score"], float)
    late = scores[steps > 0.8 * config.total_steps]
    with open(os.path.join(run_dir, "eval.json")) as f:
        evaluation = float(json.load(f)["mean"])
    return {"map": config.map_name, "algorithm": config.off_policy_correction,
            "envs": config.num_envs, "k": config.unroll_length,
            "rate": config.learning_rate, "seed": config.seed,
            "run_mean": float(scores.mean()) if len(scores) else float("nan"),
            "late_mean": float(late.mean()) if len(late) else float("nan"),
            "eval": evaluation}


def table(rows: list[dict]) -> str:
    """Each setting's mean over its seeds, then every run."""
    head = ["| map | algorithm | envs x K | rate | seeds | training mean | last fifth | "
            "evaluation |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["map"], r["algorithm"], r["envs"], r["k"]), []).append(r)
    lines = list(head)
    for (map_name, algorithm, envs, k), rs in groups.items():
        mean = {key: np.mean([r[key] for r in rs]) for key in ("run_mean", "late_mean", "eval")}
        lines.append(f"| {map_name} | {algorithm} | {envs} x {k} | {rs[0]['rate']:.2g} | "
                     f"{len(rs)} | {mean['run_mean']:.2f} | {mean['late_mean']:.2f} | "
                     f"{mean['eval']:.2f} |")
    lines += ["", "Every run:", ""] + [h.replace("seeds", "seed") for h in head]
    lines += [f"| {r['map']} | {r['algorithm']} | {r['envs']} x {r['k']} | {r['rate']:.2g} | "
              f"{r['seed']} | {r['run_mean']:.2f} | {r['late_mean']:.2f} | {r['eval']:.2f} |"
              for r in rows]
    return "\n".join(lines) + "\n"


def main(argv) -> None:
    del argv
    training_flags.start_command()
    training_flags.refuse("batch_scaling", {"map": "--maps", "num_envs": "--num_envs_list",
                                            "seed": "--seeds"})
    try:
        maps = parse_maps(_MAPS.value)
        num_envs = positive_ints("num_envs_list", _NUM_ENVS.value)
        seeds = non_negative_ints("seeds", _SEEDS.value)
        algorithms = _ALGORITHMS.value
        config = training_flags.config_from_flags()
        runs = settings(config, maps, num_envs, algorithms, seeds, _SCALING.value,
                        _PPO_RATE.value, _HOLD_BATCH.value)  # each config checked first
    except ValueError as error:
        sys.exit(f"error: {error}")
    if config.eval_episodes < 1:
        sys.exit("error: every run is scored by its evaluation; --eval_episodes >= 1")
    run_dir = training_flags.run_dir_or_temporary(config)
    rows = []
    for name, run_config in runs:
        directory = os.path.join(run_dir, name)
        if not os.path.exists(os.path.join(directory, "eval.json")):
            print(f"== {name} (rate {run_config.learning_rate:.3g})", flush=True)
            train(run_config, directory, progress=False)
        rows.append(row(run_config, directory))
    text = table(rows)
    with atomic_write(os.path.join(run_dir, "comparison.md")) as f:
        f.write(text)
    print("\n" + text)


if __name__ == "__main__":
    app.run(main)
