"""Plays the mini-games with unmodified PySC2 (pysc2-evolved) on sc2jax's SC2-API server.

PySC2 launches what it takes for the game from SC2PATH; an install layout written by
`python -m sc2jax.environment.server --write-sc2path DIR` makes that the simulator.
PySC2 needs its own environment (it pins other versions than sc2jax):

    python3 -m venv /tmp/pysc2venv && /tmp/pysc2venv/bin/pip install pysc2-evolved==1.1.1
    .venv/bin/python -m sc2jax.environment.server --write-sc2path /tmp/sc2jax-sc2path
    SC2PATH=/tmp/sc2jax-sc2path /tmp/pysc2venv/bin/python scripts/pysc2_against_the_server.py

It prints each episode's score for PySC2's own scripted and random agents.
"""

import sys

from absl import flags

flags.FLAGS(sys.argv[:1])

from pysc2_evolved.agents import random_agent, scripted_agent  # noqa: E402
from pysc2_evolved.env import sc2_env  # noqa: E402
from pysc2_evolved.lib import features  # noqa: E402

UNITS = dict(use_feature_units=True, use_raw_units=True)
RUNS = [("MoveToBeacon", scripted_agent.MoveToBeacon, 0, {}),
        ("CollectMineralShards", scripted_agent.CollectMineralShards, 0, {}),
        # Reads feature_units (the server's raw_data.units); raw_units are decoded too.
        ("CollectMineralShards", scripted_agent.CollectMineralShardsFeatureUnits, 0, UNITS),
        ("DefeatRoaches", scripted_agent.DefeatRoaches, 0, {}),
        ("DefeatRoaches", random_agent.RandomAgent, 0, UNITS),
        ("BuildMarines", random_agent.RandomAgent, 800, UNITS)]  # 800 loops: a short look.


def main() -> None:
    for map_name, agent_class, limit, options in RUNS:
        agent = agent_class()
        interface = features.AgentInterfaceFormat(
            feature_dimensions=features.Dimensions(screen=32, minimap=32), **options)
        with sc2_env.SC2Env(map_name=map_name, players=[sc2_env.Agent(sc2_env.Race.terran)],
                            agent_interface_format=interface, step_mul=8,
                            game_steps_per_episode=limit) as env:
            agent.setup(env.observation_spec()[0], env.action_spec()[0])
            scores = []
            for _ in range(2):
                timestep = env.reset()
                agent.reset()
                total = 0.0
                while not timestep[0].last():
                    timestep = env.step([agent.step(timestep[0])])
                    total += float(timestep[0].reward)
                scores.append(total)
        print(f"{map_name} {agent_class.__name__}: episode scores {scores}", flush=True)


if __name__ == "__main__":
    main()
