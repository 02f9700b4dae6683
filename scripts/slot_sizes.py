"""What the slot sizes cost in compilation and give in speed (docs/benchmarks.md, "First
steps"): the maps with `slot_sizes` compiled and run with them and on all their unit
slots (`Simulator(use_slot_sizes=False)`), one environment and 64.

    python scripts/slot_sizes.py --maps=DefeatRoaches,BuildMarines

For each map and setting, in one process: the XLA compilation of the jitted step (one
environment, then 64 vmapped), then 20 untimed no_op steps into the episode and agent
steps per second over 200 steps (one environment) or 20 (64). Prints a markdown table.
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp

from sc2jax.environment import FUNCTIONS, to_dense
from sc2jax.environment.engine.simulator import Simulator

MAPS = ("DefeatRoaches", "DefeatZerglingsAndBanelings", "CollectMineralsAndGas",
        "BuildMarines")


def _measure(sim: Simulator, num_envs: int | None) -> tuple[float, float]:
    """(compile seconds, agent steps per second) of `sim`'s jitted step."""
    action = jax.tree.map(lambda x: jnp.asarray(x)[0], to_dense([FUNCTIONS.no_op()]))
    if num_envs is None:
        state, _ = jax.jit(sim.reset)(jax.random.PRNGKey(0))
        step, repeats = sim.step, 200
    else:
        keys = jax.random.split(jax.random.PRNGKey(0), num_envs)
        state, _ = jax.jit(jax.vmap(sim.reset))(keys)
        action = jax.tree.map(lambda x: jnp.broadcast_to(x, (num_envs, *x.shape)), action)
        step, repeats = jax.vmap(sim.step), 20
    start = time.perf_counter()
    step = jax.jit(step).lower(state, action).compile()
    seconds = time.perf_counter() - start
    for _ in range(20):  # Into the episode: units spawned or trained.
        state, timestep = step(state, action)
    jax.block_until_ready(timestep)
    start = time.perf_counter()
    for _ in range(repeats):
        state, timestep = step(state, action)
    jax.block_until_ready(timestep)
    return seconds, repeats * (num_envs or 1) / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--maps", default=",".join(MAPS))
    args = parser.parse_args()
    maps = args.maps.split(",")
    unknown = sorted(set(maps) - set(MAPS))
    if unknown:
        raise SystemExit(f"unknown maps {unknown}; maps with slot sizes: {list(MAPS)}")
    print("| map | unit slots | compile, 1 env (s) | steps/s, 1 env | compile, 64 envs (s) "
          "| steps/s, 64 envs |\n|---|---|---:|---:|---:|---:|")
    for name in maps:
        for use in (True, False):
            sim = Simulator(map_name=name, use_slot_sizes=use)
            slots = sim.game.slot_sizes if use else sim.game.num_slots
            (c1, r1), (c64, r64) = _measure(sim, None), _measure(sim, 64)
            print(f"| {name} | {slots} | {c1:.1f} | {r1:,.0f} | {c64:.1f} | {r64:,.0f} |",
                  flush=True)


if __name__ == "__main__":
    main()
