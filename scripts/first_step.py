"""Seconds to the first step of each mini-game, with JAX's persistent compilation cache
cold (empty) and warm (filled by the cold run), each in a fresh process (issue 66).

Each process times `make(map)`, `reset()` and one `step(no_op)` from the call of `make`
to the step's timestep (imports excluded), at 64² with every layer, as `make`'s defaults.

    python scripts/first_step.py --maps=MoveToBeacon,DefeatRoaches
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

from sc2jax.environment.interface.map_names import MINI_GAMES

_CHILD = """
import sys, time
from sc2jax.environment import FUNCTIONS, make
start = time.perf_counter()
env = make(sys.argv[1])
env.reset()
env.step(FUNCTIONS.no_op())
print(time.perf_counter() - start)
"""


def _first_step(map_name: str, cache: str) -> float:
    env = dict(os.environ, SC2JAX_COMPILATION_CACHE=cache)
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    out = subprocess.run([sys.executable, "-c", _CHILD, map_name], env=env, check=True,
                         capture_output=True, text=True)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--maps", default=",".join(MINI_GAMES))
    args = parser.parse_args()
    maps = args.maps.split(",")
    unknown = sorted(set(maps) - set(MINI_GAMES))
    if unknown:
        raise SystemExit(f"unknown maps {unknown}; allowed: {list(MINI_GAMES)}")
    print("| Map | cache off (s) | cold (s) | warm (s) | warm / cold |")
    print("|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory(prefix="sc2jax-first-step-") as folder:
        for name in maps:
            off = _first_step(name, "0")
            cold = _first_step(name, folder)
            warm = _first_step(name, folder)
            print(f"| {name} | {off:.1f} | {cold:.1f} | {warm:.1f} | {warm / cold:.2f} |",
                  flush=True)


if __name__ == "__main__":
    main()
