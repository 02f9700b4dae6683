"""Requests per second of the SC2-API server for ping, observation and step, for two
source trees side by side (issue 67: the guards must not slow requests by more than 5%).

Each tree's server runs in its own process (`python -m sc2jax.environment.server` with
the tree first on PYTHONPATH); one client plays MoveToBeacon at 64² on each, and the
rounds alternate between them, in turn first, so that both see the same machine load. Compilation is
excluded (warm-up requests first).

    git worktree add /tmp/before 5bce356
    python scripts/server_requests.py --trees=/tmp/before,. --rounds=5 --requests=300
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import time

from sc2jax.environment.sc2api.controller import Controller
from sc2jax.environment.sc2api.protos import sc2api

KINDS = ("ping", "observation", "step")


def _start(tree: str) -> tuple[subprocess.Popen, int]:
    env = dict(os.environ, PYTHONPATH=os.path.abspath(tree))
    server = subprocess.Popen([sys.executable, "-m", "sc2jax.environment.server", "--port",
                               "0"], stdout=subprocess.PIPE, text=True, env=env)
    line = server.stdout.readline()
    port = int(re.search(r":(\d+)/sc2api", line).group(1))
    return server, port


def _join(controller: Controller) -> None:
    controller.create_game(map_path="MoveToBeacon.SC2Map", random_seed=0)
    options = sc2api.InterfaceOptions(score=True)
    layers = options.feature_layer
    layers.width, layers.resolution.x, layers.resolution.y = 24, 64, 64
    layers.minimap_resolution.x = layers.minimap_resolution.y = 64
    controller.join_game(options)


def _rate(controller: Controller, kind: str, count: int) -> float:
    request = {"ping": controller.ping, "observation": controller.observe,
               "step": lambda: controller.step(8)}[kind]
    start = time.perf_counter()
    for _ in range(count):
        request()
    return count / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trees", default=".", help="comma-separated source trees")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--requests", type=int, default=300)
    args = parser.parse_args()
    trees = args.trees.split(",")
    servers, clients = [], []
    try:
        for tree in trees:
            server, port = _start(tree)
            servers.append(server)
            controller = Controller.connect("127.0.0.1", port)
            _join(controller)
            for kind in KINDS:  # Warm-up: compiles.
                _rate(controller, kind, 20)
            clients.append(controller)
        rates = {(i, kind): [] for i in range(len(trees)) for kind in KINDS}
        for round_ in range(args.rounds):
            order = list(enumerate(clients))
            for i, controller in order if round_ % 2 == 0 else order[::-1]:
                for kind in KINDS:
                    if kind == "step" and controller.status != sc2api.Status.Value("in_game"):
                        controller.restart()
                    rates[i, kind].append(_rate(controller, kind, args.requests))
        print("| request | " + " | ".join(f"{t}: requests/s (median of {args.rounds})"
                                           for t in trees) + " | ratio |")
        print("|---|" + "---:|" * (len(trees) + 1))
        for kind in KINDS:
            medians = [statistics.median(rates[i, kind]) for i in range(len(trees))]
            print(f"| {kind} | " + " | ".join(f"{m:,.0f}" for m in medians)
                  + f" | {medians[-1] / medians[0]:.3f} |")
    finally:
        for controller in clients:
            controller.close()
        for server in servers:
            server.kill()


if __name__ == "__main__":
    main()
