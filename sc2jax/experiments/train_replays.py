r"""Trains a dual-headed network on a replay dataset (the paper's section 5), then
evaluates it on the held-out games.

    python -m sc2jax.experiments.convert_replays --replays=../shared/replays \
        --output=/data/replays64
    python -m sc2jax.experiments.train_replays --dataset=/data/replays64 \
        --network=fullyconv --steps=20000 --run_dir=/tmp/runs/sl_fullyconv
    python -m sc2jax.experiments.train_replays --dataset=/data/replays64 \
        --network=arfullyconv --steps=0 --run_dir=/tmp/runs/sl_random   # a random baseline

The network predicts the game's outcome (value) and the player's next action (policy)
from the observation, trained with `sc2jax.losses`' supervised loss under the records'
`available_actions`. The run directory gets checkpoints, train.csv and test.csv,
TensorBoard events, eval.json (Table 2's accuracies, the value's accuracy by game time,
the next build command's accuracy and the most-frequent-function baseline) and
curves.png. Running the same command again resumes from the last checkpoint.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile

from absl import app, flags

from sc2jax.experiments.replay_training.config import AGENTS, ReplayTrainConfig
from sc2jax.experiments.replay_training.trainer import train_replays
from sc2jax.experiments.training import flags as training_flags

_HELP = {
    "dataset": "The dataset's folder (written by convert_replays).",
    "agent": f"Network: one of {list(AGENTS)}.",  # --network
    "steps": "Adam updates (0: evaluate the untrained network).",
    "batch_size": "Records per update.",
    "learning_rate": "Adam's learning rate (default: 1e-3, but 1e-4 for fullyconv and "
                     "arfullyconv above 32x32).",
    "value_weight": "Weight of the value loss against the policy loss.",
    "log_every": "Updates between rows of train.csv.",
    "eval_every": "Updates between held-out evaluations (test.csv).",
    "eval_batches": "Held-out minibatches per periodic evaluation.",
    "final_eval_batches": "Held-out minibatches of the final evaluation (eval.json).",
    "checkpoint_every": "Updates between checkpoints.",
    "seed": "Seed of the parameters and of the shuffles.",
}
_DEFINE = {str: flags.DEFINE_string, int: flags.DEFINE_integer, float: flags.DEFINE_float,
           type(None): flags.DEFINE_float}  # learning_rate: None, a default
_FLAG_NAMES = {"agent": "network"}  # A config field -> its flag, where they differ.
_FLAGS = {f.name: _DEFINE[type(f.default) if f.default is not dataclasses.MISSING else str](
    _FLAG_NAMES.get(f.name, f.name), None if f.default is dataclasses.MISSING else f.default,
    _HELP[f.name]) for f in dataclasses.fields(ReplayTrainConfig)}
flags.DEFINE_alias("agent", "network")  # The old name (as in train).
_RUN_DIR = flags.DEFINE_string("run_dir", None, "The run's folder (default: a new temporary "
                               "one); a run there is resumed.")


def main(argv) -> None:
    del argv
    training_flags.start_command()
    if not _FLAGS["dataset"].value:
        sys.exit("error: --dataset is required")
    try:
        config = ReplayTrainConfig(**{name: flag.value for name, flag in _FLAGS.items()})
    except ValueError as error:
        sys.exit(f"error: {error}")
    run_dir = _RUN_DIR.value or tempfile.mkdtemp(prefix=f"sc2jax_replays_{config.agent}_")
    print(f"Run directory: {os.path.abspath(run_dir)}", flush=True)
    try:
        result = train_replays(config, run_dir)
    except ValueError as error:
        sys.exit(f"error: {error}")
    pct = lambda v: "n/a" if v is None else f"{100 * v:.1f}%"  # noqa: E731
    print(f"\nHeld-out games, {result['examples']} records, after {result['updates']} updates:")
    print("| | top-1 | top-5 |\n|---|---:|---:|")
    for name, label in (("action", "function"), ("screen", "screen"), ("minimap", "minimap"),
                        ("build", "build commands"),
                        ("next_build", "next build command, among build commands"),
                        ("majority", f"most frequent ({result['majority_function']})")):
        print(f"| {label} | {pct(result[f'{name}_top1'])} | {pct(result[f'{name}_top5'])} |")
    print(f"Value accuracy {pct(result['value_accuracy'])} (after 15 minutes: "
          f"{pct(result['value_after_15_min'])})")
    print(f"Results in {os.path.abspath(run_dir)}")


if __name__ == "__main__":
    app.run(main)
