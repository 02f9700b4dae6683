"""How CollectMineralShards scores depend on the shard pickup distance (docs/fidelity.md).

    python scripts/shard_pickup_sensitivity.py --distances=0.75,1,1.5,2,2.5,3
    python scripts/shard_pickup_sensitivity.py --distances=0.75,1,1.5,2 --size=16

The game's pickup distance is not in the map file (it is set in the Liberty campaign
mod), so the simulator uses the touching distance, 0.75 (a marine's radius plus a
shard's). This re-runs the random and scripted agents with other distances and prints
one markdown row per distance and agent: mean, std, max, beside the paper's rows.
`--size` sets the screen and minimap resolution (default 64): the scripted agent clicks
on a shard's pixel, whose centre is up to 0.53 world units from the shard at 32² and
1.06 at 16², so at 16² it depends on the pickup distance more than at 64².
"""

import argparse
import time

from sc2jax.environment import make
from sc2jax.environment import sc2_env as environments
from sc2jax.environment.agents import required_format
from sc2jax.environment.engine.minigames import collect_mineral_shards
from sc2jax.experiments.reporting.paper import TABLE1
from sc2jax.experiments.training import evaluation

MAP = "CollectMineralShards"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--distances", default="0.75,1,1.25,1.5,2,2.5,3")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--num_envs", type=int, default=50)
    parser.add_argument("--size", type=int, default=64)
    args = parser.parse_args()
    distances = [float(d) for d in args.distances.split(",")]
    if any(d <= 0 for d in distances):
        raise ValueError(f"--distances must be positive, got {args.distances!r}")
    paper = {row: TABLE1[row][MAP] for row in ("random_policy", "deepmind_human")}
    print(f"Paper: random policy {paper['random_policy'][0]:g} / {paper['random_policy'][1]:g}"
          f", DeepMind human {paper['deepmind_human'][0]:g} / {paper['deepmind_human'][1]:g}"
          " (mean / max)\n")
    print("| pickup distance | agent | episodes | mean | std | max | wall s |")
    print("|---|---|---|---|---|---|---|")
    for distance in distances:
        # Read when the step is traced: each distance needs a freshly built simulator.
        collect_mineral_shards.PICKUP_DISTANCE = distance
        for agent in ("random", "scripted"):
            environments.simulator.cache_clear()
            extra = required_format(MAP) if agent == "scripted" else {}
            sim = make(MAP, screen_size=args.size, minimap_size=args.size, **extra).simulator
            start = time.time()
            stats = evaluation.run_episodes(sim, evaluation.make_policy(agent, MAP, sim.fmt),
                                            args.episodes, args.num_envs, seed=1)
            s = stats.summary
            print(f"| {distance:g} | {agent} | {s['episodes']} | {s['mean']:.2f} "
                  f"| {s['std']:.2f} | {s['max']:g} | {time.time() - start:.0f} |", flush=True)


if __name__ == "__main__":
    main()
