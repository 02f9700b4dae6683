"""Scores of agents written against PySC2's API (tests/environment/pysc2/pysc2_agents.py,
loaded with only their imports changed) and of PySC2's random agent, on the simulator
through `sc2jax.environment.pysc2` at 84² screen and 64² minimap (docs/usage.md).

    PYTHONPATH=. python scripts/pysc2_agent_scores.py --episodes=10 --seed=7
"""

from __future__ import annotations

import argparse

import numpy as np

from sc2jax.environment.pysc2.agents import random_agent
from tests.environment.pysc2.test_pysc2_api import _env, _play, load_pysc2_agents

AGENTS = (("MoveToBeacon", "MoveToBeacon", {}),
          ("CollectMineralShards", "CollectMineralShards", {}),
          ("CollectMineralShardsFeatureUnits", "CollectMineralShards",
           {"use_feature_units": True}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    module = load_pysc2_agents()
    rows = []
    for name, map_name, interface in AGENTS:
        with _env(map_name, args.seed, **interface) as env:
            rows.append((name, map_name, _play(getattr(module, name)(), env, args.episodes)))
    np.random.seed(args.seed)
    with _env("MoveToBeacon", args.seed) as env:
        rows.append(("PySC2's RandomAgent", "MoveToBeacon",
                     _play(random_agent.RandomAgent(), env, args.episodes)))
    print(f"| agent | map | mean ± std over {args.episodes} episodes |")
    print("|---|---|---:|")
    for name, map_name, scores in rows:
        print(f"| {name} | {map_name} | {np.mean(scores):.1f} ± {np.std(scores):.1f} |")


if __name__ == "__main__":
    main()
