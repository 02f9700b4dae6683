r"""Table 1 for sc2jax: a learning-rate sweep on each mini-game, beside the paper's rows.

    python -m sc2jax.experiments.table1 --network=fullyconv --num_runs=8 \
        --total_steps=60000000 --run_dir=/tmp/table1

Takes the flags of `sweep` (and so of `train`), except that --maps (default: all
seven) replaces --map, plus --random_episodes. For each map it runs the sweep in
RUN_DIR/MAP, then the paper's random policy (uniform over every available function, at
the sweep's resolution and step_mul) for --random_episodes episodes, and then writes
RUN_DIR/table1.md and RUN_DIR/table1.json.

An interrupted table resumes where it stopped (see `tables`). With --num_processes (or
under SLURM or Open MPI) every map's sweep is split over the processes, as `sweep` splits
one, and the last process to finish writes the table.
"""

from __future__ import annotations

import dataclasses
import os
import sys

from absl import app, flags

from sc2jax.experiments.sweeps import flags as sweep_flags
from sc2jax.experiments.sweeps.tables import build_table1, parse_maps, table1_markdown
from sc2jax.experiments.training import flags as training_flags

training_flags.define_training()
training_flags.define_processes(coordinator=False)
_MAPS = flags.DEFINE_string("maps", "all", "Comma-separated mini-games, or 'all' (the "
                            "seven, in the paper's order).")
_RANDOM_EPISODES = flags.DEFINE_integer("random_episodes", 100, "Episodes of the random "
                                        "policy per map (0: leave its column empty).")

FLAGS = flags.FLAGS

flags.adopt_module_key_flags(training_flags)
flags.adopt_module_key_flags(sweep_flags)


def main(argv) -> None:
    del argv
    training_flags.start_command()
    training_flags.refuse("table1", {"map": "--maps (comma-separated, or 'all')"})
    try:
        maps = parse_maps(_MAPS.value)
        config = dataclasses.replace(training_flags.config_from_flags(), map_name=maps[0])
        rates = sweep_flags.learning_rates_from_flags()
        if _RANDOM_EPISODES.value < 0:
            raise ValueError(f"--random_episodes must be >= 0, got {_RANDOM_EPISODES.value}")
        part = training_flags.sweep_part()
    except ValueError as error:
        sys.exit(f"error: {error}")
    run_dir = training_flags.run_dir_or_temporary(config)
    print(f"Table directory: {os.path.abspath(run_dir)}\nMaps: {', '.join(maps)}\n"
          f"Learning rates: {', '.join(f'{r:.2e}' for r in rates)}", flush=True)
    try:
        table = build_table1(config, maps, rates, run_dir, _RANDOM_EPISODES.value, part=part)
    except ValueError as error:
        sys.exit(f"error: {error}")
    if table is None:
        print("This process's parts are done; the last process to finish writes the table")
        return
    print("\n" + table1_markdown(table))
    print(f"Wrote {os.path.join(run_dir, 'table1.md')} and table1.json")


if __name__ == "__main__":
    app.run(main)
