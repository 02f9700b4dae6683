r"""Training throughput over devices and processes at a fixed global batch: the train
command as 1 process x 1 device, 1 process x 2 devices and 2 processes x 1 device
(jax.distributed on a localhost coordinator), each run `--repeats` times in turn; with
`--compare=pipelined`, the compiled loop against the pipelined one (`--pipelined`).

    python scripts/process_scaling.py --repeats=2 [-- extra train flags]
    python scripts/process_scaling.py --compare=pipelined --repeats=2 [-- extra train flags]

Prints, for each setting, the median agent steps/s of each run's chunks after the first
(compiling) one: the steps_per_s column of its metrics.csv.
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile

import numpy as np

from sc2jax.experiments.reporting.metrics_log import read_csv

COMPARISONS = {
    "processes": {"1 process x 1 device": (1, 1, []), "1 process x 2 devices": (1, 2, []),
                  "2 processes x 1 device": (2, 1, [])},
    "pipelined": {"act, then learn": (1, 1, []),
                  "act beside learning (--pipelined)": (1, 1, ["--pipelined"])},
}
"""Settings compared: name -> (processes, devices per process, extra train flags)."""
BASE = ["--preset=beacon_quickstart", "--num_envs=16", "--total_steps=20480",
        "--eval_episodes=0", "--compilation_cache="]


def _port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def run(processes: int, devices: int, run_dir: str, extra: list[str]) -> float:
    """One run's median agent steps/s after its first chunk."""
    command = [sys.executable, "-m", "sc2jax.experiments.train", *BASE, *extra,
               f"--devices={devices}", f"--run_dir={run_dir}"]
    if processes > 1:
        coordinator = f"localhost:{_port()}"
        command += [f"--coordinator={coordinator}", f"--num_processes={processes}"]
    workers = [subprocess.Popen(command + ([f"--process_id={i}"] if processes > 1 else []),
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
               for i in range(processes)]
    for worker in workers:
        _, err = worker.communicate()
        if worker.returncode:
            raise RuntimeError(err[-2000:])
    return float(np.median(read_csv(os.path.join(run_dir, "metrics.csv"))["steps_per_s"][1:]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--compare", choices=sorted(COMPARISONS), default="processes")
    args, extra = parser.parse_known_args()
    extra = [a for a in extra if a != "--"]
    settings = COMPARISONS[args.compare]
    results = {name: [] for name in settings}
    with tempfile.TemporaryDirectory() as root:
        for repeat in range(args.repeats):
            for i, (name, (processes, devices, flags)) in enumerate(settings.items()):
                run_dir = os.path.join(root, f"{i}-{repeat}")
                results[name].append(run(processes, devices, run_dir, [*flags, *extra]))
                print(f"{name}: {results[name][-1]:.0f} agent steps/s", flush=True)
    print("\n| setting | agent steps/s |\n|---|---:|")
    for name, values in results.items():
        print(f"| {name} | {', '.join(f'{v:.0f}' for v in values)} |")


if __name__ == "__main__":
    main()
