r"""A hyper-parameter sweep like the paper's: N runs with sampled learning rates,
trained together (vmapped in one program on an accelerator).

    python -m sc2jax.experiments.sweep --map=MoveToBeacon --network=fullyconv \
        --num_runs=8 --total_steps=2000000 --run_dir=/tmp/sweeps/beacon
    python -m sc2jax.experiments.sweep --num_processes=2 --process_id=0 ...  # and 1

With --num_processes (or under SLURM or Open MPI, from the cluster's environment), each
process trains its own block of the runs, with no traffic between them, in a directory
every process sees; the last to finish writes the summary (`sweeping.run_sweep`).

Takes every flag of `sc2jax.experiments.train` (the shared config, --preset included;
--learning_rate is replaced by the sampled rates) plus the sampling range. Prints
Table 1's entries for the sweep (the mean over runs, the best run's mean and the max
episode score) beside the paper's.
"""

from __future__ import annotations

import os
import sys

from absl import app, flags

from sc2jax.experiments.reporting.paper import paper_rows
from sc2jax.experiments.sweeps import flags as sweep_flags
from sc2jax.experiments.sweeps.sweeping import run_sweep
from sc2jax.experiments.training import flags as training_flags

training_flags.define_training()
training_flags.define_processes(coordinator=False)

flags.adopt_module_key_flags(training_flags)
flags.adopt_module_key_flags(sweep_flags)


def main(argv) -> None:
    del argv
    training_flags.start_command()
    try:
        config = training_flags.config_from_flags()
        rates = sweep_flags.learning_rates_from_flags()
        part = training_flags.sweep_part()
    except ValueError as error:
        sys.exit(f"error: {error}")
    sweep_dir = training_flags.run_dir_or_temporary(config)
    print(f"Sweep directory: {os.path.abspath(sweep_dir)}\nLearning rates: "
          f"{', '.join(f'{r:.2e}' for r in rates)}", flush=True)
    try:
        summary = run_sweep(config, rates, sweep_dir, part=part)
    except ValueError as error:
        sys.exit(f"error: {error}")
    if not summary.get("complete", True):
        print(f"Runs {summary['runs']} are done; the last process to finish writes "
              f"{os.path.join(os.path.abspath(sweep_dir), 'sweep.json')}")
        return
    print(f"\n{config.map_name}, {config.agent}, {len(rates)} runs of "
          f"{summary['agent_steps_per_run']} agent steps [{summary['seconds'] / 60:.1f} min]:")
    best = summary["best_run"]
    where = "" if best is None else f" (run {best}, lr {rates[best]:.2e})"
    print(f"  mean over runs {summary['mean_over_runs']:.2f}   best mean "
          f"{summary['best_mean']:.2f}{where}   max {summary['max']:g}")
    print("The paper's Table 1:")
    print(paper_rows(config.map_name))


if __name__ == "__main__":
    app.run(main)
