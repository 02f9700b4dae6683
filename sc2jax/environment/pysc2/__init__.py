"""PySC2 v4's API over the simulator: a PySC2 agent runs with its imports changed from
`pysc2` to `sc2jax.environment.pysc2`, and nothing else.

    from sc2jax.environment.pysc2.agents import base_agent
    from sc2jax.environment.pysc2.env import run_loop, sc2_env
    from sc2jax.environment.pysc2.lib import actions, features, units

    python -m sc2jax.environment.pysc2.bin.agent --map MoveToBeacon --agent mymodule.MyAgent

The modules keep PySC2's names and signatures: `env.sc2_env.SC2Env` (one agent on a
mini-game; a tuple of `TimeStep`s from `reset` and `step`), `env.run_loop.run_loop`,
`agents.base_agent.BaseAgent`, `agents.random_agent.RandomAgent`, and `lib.actions`,
`lib.features`, `lib.units`, `lib.named_array`. Observations are named as PySC2's are
(`obs.observation.feature_screen.player_relative`, `obs.observation["player"].minerals`).
What the simulator does not do (other races, bots, RGB observations, raw actions, the
viewer, replays) is refused with a ValueError naming the option.
"""
