"""Measures the random and scripted agents on every simulator map (docs/fidelity.md).

    python scripts/fidelity_table.py --episodes=100 > /tmp/fidelity_rows.md

Prints one markdown row per map and agent: mean, std, max over the episodes, beside the
paper's Table 1 (random policy, DeepMind human, GrandMaster).
"""

import argparse
import time

from sc2jax.environment import MAPS, make
from sc2jax.environment.agents import SCRIPTED_MAPS, required_format
from sc2jax.experiments.reporting.paper import TABLE1
from sc2jax.experiments.training import evaluation


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--num_envs", type=int, default=50)
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--maps", default=",".join(MAPS))
    parser.add_argument("--agents", default="random,scripted")
    args = parser.parse_args()
    print("| map | agent | episodes | mean | std | max | paper random (mean/max) "
          "| paper human (mean/max) | paper GrandMaster (mean/max) | wall s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in args.maps.split(","):
        for agent in args.agents.split(","):
            if agent == "scripted" and name not in SCRIPTED_MAPS:
                continue
            extra = required_format(name) if agent == "scripted" else {}
            sim = make(name, screen_size=args.size, minimap_size=args.size, **extra).simulator
            start = time.time()
            stats = evaluation.run_episodes(sim, evaluation.make_policy(agent, name, sim.fmt),
                                            args.episodes, args.num_envs, seed=1)
            s = stats.summary
            paper = " | ".join(f"{TABLE1[row][name][0]:g} / {TABLE1[row][name][1]:g}"
                               for row in ("random_policy", "deepmind_human", "grandmaster"))
            print(f"| {name} | {agent} | {s['episodes']} | {s['mean']:.2f} | {s['std']:.2f} "
                  f"| {s['max']:g} | {paper} | {time.time() - start:.0f} |", flush=True)


if __name__ == "__main__":
    main()
