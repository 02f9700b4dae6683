r"""Trains an agent on a mini-game of the embedded simulator (or on StarCraft II
itself), then evaluates it.

    python -m sc2jax.experiments.train --preset=beacon_quickstart
    python -m sc2jax.experiments.train --map=MoveToBeacon --network=fullyconv \
        --total_steps=5000000 --run_dir=/tmp/runs/beacon
    python -m sc2jax.experiments.train --backend=sc2 --num_envs=8 ...   # the real game
    python -m sc2jax.experiments.train --backend=sc2 --map=Simple64 --bot=terran,easy
    python -m sc2jax.experiments.train --coordinator=host0:1234 --num_processes=2 \
        --process_id=0 --run_dir=/shared/runs/beacon ...   # on every host, its own id

A named configuration (`--preset`, see `training.presets`) sets several flags at once;
a flag given on the command line overrides it. Defaults follow the paper: 64x64 feature
layers, step_mul 8, K = 40, entropy 1e-3, RMSProp with the learning rate annealed
linearly to half. The run directory gets the resolved config, Orbax checkpoints,
metrics.csv, TensorBoard events, every training episode's score, a learning-curve PNG
and the final evaluation (eval.json). Running the same command again resumes from the
last checkpoint.
"""

from __future__ import annotations

import dataclasses
import os
import sys

from absl import app, flags

from sc2jax.environment.engine.xla.devices import use_cpu_cores
from sc2jax.environment.interface.map_names import MINI_GAMES
from sc2jax.experiments.reporting.paper import paper_rows
from sc2jax.experiments.training import data_parallel
from sc2jax.experiments.training import flags as training_flags
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.trainer import train

training_flags.define_training()
training_flags.define_processes()
_DEVICES = flags.DEFINE_integer(
    "devices", 1, "How many devices of each process to split the environments over "
    "(data-parallel training, sc2jax.experiments.training.data_parallel); on a CPU, that "
    "many host devices are made. --num_envs must be a multiple of it times the number of "
    "processes.", lower_bound=1)
_DEFAULTS = TrainConfig()

flags.adopt_module_key_flags(training_flags)


def main(argv) -> None:
    del argv
    if _DEVICES.value > 1:
        use_cpu_cores(_DEVICES.value)  # Before JAX starts; no change on an accelerator.
    try:
        training_flags.join_processes()
    except ValueError as error:
        sys.exit(f"error: {error}")
    training_flags.start_command()
    say = print if data_parallel.is_primary() else (lambda *args, **kwargs: None)
    try:
        config = training_flags.config_from_flags()
    except ValueError as error:
        sys.exit(f"error: {error}")
    run_dir = training_flags.run_dir_or_temporary(config)
    changed = {k: v for k, v in dataclasses.asdict(config).items()
               if getattr(_DEFAULTS, k) != v}
    say(f"Run directory: {os.path.abspath(run_dir)}\nSettings changed from the paper's "
          f"defaults: {changed or 'none'}", flush=True)
    try:
        result = train(config, run_dir, sc2path=training_flags.FLAGS.sc2path,
                       devices=_DEVICES.value)
    except ValueError as error:
        sys.exit(f"error: {error}")
    say(f"\nTrained for {result.seconds / 60:.1f} min; "
          f"{result.episode_scores.size} training episodes")
    if result.evaluation:
        s = result.evaluation
        say(f"{config.map_name}, trained {config.agent}: mean {s['mean']:.2f} ± "
              f"{s['std']:.2f} (std), max {s['max']:g}, over {s['episodes']} episodes")
        if result.best_evaluation:
            b = result.best_evaluation
            say(f"  its best parameters (at {b['env_steps']} agent steps, "
                  f"{b['chosen_by']} score {b['score']:.2f}): mean {b['mean']:.2f} ± "
                  f"{b['std']:.2f} (std), max {b['max']:g}")
        if config.map_name in MINI_GAMES:
            say("The paper's Table 1:")
            say(paper_rows(config.map_name))
    say(f"Results in {os.path.abspath(run_dir)}")


if __name__ == "__main__":
    app.run(main)
