r"""The Table 1 campaign for one GPU: trains one run per map with the `table1_gpu` preset,
evaluates it, and prints which maps reached the paper's FullyConv best mean and the GPU
time each took.

    python scripts/table1_gpu.py --run_dir=runs/table1_gpu
    python scripts/table1_gpu.py --run_dir=runs/table1_gpu --maps=MoveToBeacon,DefeatRoaches
    # A dry run on a CPU: any training flag overrides the preset.
    python scripts/table1_gpu.py --run_dir=/tmp/t1 --maps=MoveToBeacon --screen_size=16 \
        --minimap_size=16 --num_envs=4 --total_steps=2048 --eval_episodes=4

Each map trains in RUN_DIR/MAP (`train`'s run directory: running the script again resumes
every map from its checkpoint and skips the finished ones). The seconds each map spent in
training and evaluation are added up over resumptions in RUN_DIR/MAP/gpu_seconds.json.
RUN_DIR/campaign.md gets the table that is printed.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time

from absl import app, flags

from sc2jax.atomic import atomic_write, write_json_atomic
from sc2jax.experiments.reporting.paper import TABLE1
from sc2jax.experiments.sweeps.tables import parse_maps
from sc2jax.experiments.training import flags as training_flags
from sc2jax.experiments.training.trainer import train

training_flags.define_training()
_MAPS = flags.DEFINE_string("maps", "all", "Comma-separated mini-games, or 'all'.")
flags.adopt_module_key_flags(training_flags)
FLAGS = flags.FLAGS


def _seconds(run_dir: str) -> float:
    path = os.path.join(run_dir, "gpu_seconds.json")
    if not os.path.exists(path):
        return 0.0
    with open(path) as f:
        return float(json.load(f)["seconds"])


def run_map(config, run_dir: str) -> dict:
    """Trains and evaluates one map (or reads its finished run): its row of the table."""
    done = os.path.join(run_dir, "eval.json")
    if not os.path.exists(done):
        start = time.time()
        try:
            train(config, run_dir, progress=False)
        finally:  # An interrupted map keeps the time it spent.
            write_json_atomic(os.path.join(run_dir, "gpu_seconds.json"),
                              {"seconds": _seconds(run_dir) + time.time() - start})
    with open(done) as f:
        mean = float(json.load(f)["mean"])
    target = TABLE1["fullyconv"][config.map_name][0]
    return {"map": config.map_name, "target": target, "mean": mean, "reached": mean >= target,
            "minutes": _seconds(run_dir) / 60, "agent_steps": config.total_steps}


def main(argv) -> None:
    del argv
    training_flags.start_command()
    training_flags.refuse("table1_gpu", {"map": "--maps (comma-separated, or 'all')"})
    if not FLAGS["preset"].present:
        FLAGS.preset = "table1_gpu"
    try:
        maps = parse_maps(_MAPS.value)
        config = training_flags.config_from_flags()
    except ValueError as error:
        sys.exit(f"error: {error}")
    if config.eval_episodes < 1:
        sys.exit("error: the campaign scores each map by its evaluation; --eval_episodes >= 1")
    run_dir = training_flags.run_dir_or_temporary(config)
    rows = []
    for name in maps:
        print(f"== {name}", flush=True)
        rows.append(run_map(dataclasses.replace(config, map_name=name),
                            os.path.join(run_dir, name)))
    lines = ["| map | paper FullyConv best mean | mean | reached | device minutes | agent steps |",
             "|---|---:|---:|---|---:|---:|"]
    lines += [f"| {r['map']} | {r['target']:g} | {r['mean']:.2f} | "
              f"{'yes' if r['reached'] else 'no'} | {r['minutes']:.1f} | "
              f"{r['agent_steps']:,} |" for r in rows]
    text = "\n".join(lines) + "\n"
    with atomic_write(os.path.join(run_dir, "campaign.md")) as f:
        f.write(text)
    print("\n" + text + f"{sum(r['reached'] for r in rows)} of {len(rows)} maps reached "
          f"their targets; {sum(r['minutes'] for r in rows):.1f} device minutes in all.")


if __name__ == "__main__":
    app.run(main)
