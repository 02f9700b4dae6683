r"""A hyper-parameter sweep like the paper's: N runs with sampled learning rates,
trained together (vmapped in one program on an accelerator).

    python -m sc2jax.experiments.sweep --map=MoveToBeacon --agent=fullyconv \
        --num_runs=8 --total_steps=2000000 --run_dir=/tmp/sweeps/beacon

Takes every flag of `sc2jax.experiments.train` (the shared config; --learning_rate is
replaced by the sampled rates) plus the sampling range. Prints Table 1's entries for
the sweep (the mean over runs, the best run's mean and the max episode score) beside
the paper's.
"""

from __future__ import annotations

import os
import sys

import jax
from absl import app, flags

from sc2jax.experiments import train as train_flags
from sc2jax.experiments.paper import paper_rows
from sc2jax.experiments.sweeping import run_sweep, sample_learning_rates

_NUM_RUNS = flags.DEFINE_integer("num_runs", 8, "Runs in the sweep (trained together).")
_LR_MIN = flags.DEFINE_float("lr_min", 1e-5, "Smallest sampled learning rate.")
_LR_MAX = flags.DEFINE_float("lr_max", 1e-3, "Largest sampled learning rate.")
_SWEEP_SEED = flags.DEFINE_integer("sweep_seed", 0, "Seed of the sampled learning rates.")


def learning_rates_from_flags():
    """float32[--num_runs] rates sampled by the flags (ValueError for a bad value)."""
    return sample_learning_rates(jax.random.PRNGKey(_SWEEP_SEED.value), _NUM_RUNS.value,
                                 _LR_MIN.value, _LR_MAX.value)


def main(argv) -> None:
    del argv
    try:
        config = train_flags.config_from_flags()
        rates = learning_rates_from_flags()
    except ValueError as error:
        sys.exit(f"error: {error}")
    sweep_dir = train_flags.run_dir_or_temporary(config)
    print(f"Sweep directory: {os.path.abspath(sweep_dir)}\nLearning rates: "
          f"{', '.join(f'{r:.2e}' for r in rates)}", flush=True)
    try:
        summary = run_sweep(config, rates, sweep_dir)
    except ValueError as error:
        sys.exit(f"error: {error}")
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
