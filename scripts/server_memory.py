"""The SC2-API server's memory over requests that mix step counts and formats (issue 67:
compiled programs are bounded).

A server process (`python -m sc2jax.environment.server`) serves one client, which plays
games in turn on `FORMATS` (more than `programs.MAX_FORMATS`, cycled, so that every join
after the first few drops a program set and compiles one) and sends, in each game,
actions, observations and steps of random counts (log-uniform in 1..10,000). The
server's resident memory (VmRSS, and its peak VmHWM) is read from /proc after each join
and at the end.

    python scripts/server_memory.py --requests=1000 --per_game=50
"""

from __future__ import annotations

import argparse
import pathlib
import re
import subprocess
import sys
import time

import numpy as np

from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall
from sc2jax.environment.sc2api import proto_actions
from sc2jax.environment.sc2api.controller import Controller
from sc2jax.environment.sc2api.protos import sc2api

FORMATS = (("MoveToBeacon", 16, False), ("MoveToBeacon", 32, False),
           ("MoveToBeacon", 32, True), ("MoveToBeacon", 64, False),
           ("CollectMineralShards", 32, False), ("DefeatRoaches", 32, False))
"""(map, screen and minimap size, raw units)."""


def _memory_mb(pid: int) -> tuple[float, float]:
    """(VmRSS, VmHWM) of process `pid`, in MB."""
    status = pathlib.Path(f"/proc/{pid}/status").read_text()
    return tuple(int(re.search(rf"{k}:\s+(\d+) kB", status).group(1)) / 1024
                 for k in ("VmRSS", "VmHWM"))


def _join(controller: Controller, map_name: str, size: int, raw: bool) -> None:
    controller.create_game(map_path=f"{map_name}.SC2Map", random_seed=0)
    options = sc2api.InterfaceOptions(raw=raw, score=True)
    layers = options.feature_layer
    layers.width, layers.resolution.x, layers.resolution.y = 24, size, size
    layers.minimap_resolution.x = layers.minimap_resolution.y = size
    controller.join_game(options)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--requests", type=int, default=1000)
    parser.add_argument("--per_game", type=int, default=50,
                        help="requests in each game, its create and join included")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.per_game < 3 or args.requests < args.per_game:
        raise SystemExit(f"need 3 <= --per_game <= --requests, got {args.per_game}, "
                         f"{args.requests}")
    rng = np.random.default_rng(args.seed)
    server = subprocess.Popen([sys.executable, "-m", "sc2jax.environment.server", "--port",
                               "0"], stdout=subprocess.PIPE, text=True)
    port = int(re.search(r":(\d+)/sc2api", server.stdout.readline()).group(1))
    controller = Controller.connect("127.0.0.1", port)
    army = sc2api.RequestAction(actions=[proto_actions.to_proto(
        FunctionCall(FUNCTIONS.select_army.id, [[0]]))])
    print("| requests | games | format | step counts so far | RSS MB | peak MB | s |")
    print("|---:|---:|---|---:|---:|---:|---:|")
    start, sent, games, counts = time.perf_counter(), 0, 0, set()
    try:
        print(f"| 0 | 0 | (launched) | 0 | {_memory_mb(server.pid)[0]:.0f} | "
              f"{_memory_mb(server.pid)[1]:.0f} | 0 |", flush=True)
        while sent < args.requests:
            map_name, size, raw = FORMATS[games % len(FORMATS)]
            _join(controller, map_name, size, raw)
            sent, games = sent + 2, games + 1
            rss, peak = _memory_mb(server.pid)
            print(f"| {sent} | {games} | {map_name} {size}²{' raw' if raw else ''} | "
                  f"{len(counts)} | {rss:.0f} | {peak:.0f} | "
                  f"{time.perf_counter() - start:.0f} |", flush=True)
            for _ in range(min(args.per_game - 3, args.requests - sent - 1)):
                kind = rng.integers(3)
                if controller.status == sc2api.Status.Value("ended"):
                    controller.restart()
                elif kind == 0:
                    controller._exchange("action", sc2api.Request(action=army))
                elif kind == 1:
                    controller.observe()
                else:
                    count = int(np.exp(rng.uniform(0, np.log(10_000))))
                    counts.add(count)
                    controller.step(count)
                sent += 1
            controller.leave()
            sent += 1
        rss, peak = _memory_mb(server.pid)
        print(f"| {sent} | {games} | (left) | {len(counts)} | {rss:.0f} | {peak:.0f} | "
              f"{time.perf_counter() - start:.0f} |")
    finally:
        controller.close()
        server.kill()


if __name__ == "__main__":
    main()
