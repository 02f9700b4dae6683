"""PySC2's `pysc2.agents.random_agent`: a uniformly random available function with
uniformly random arguments (the paper's random baseline)."""

from __future__ import annotations

import numpy as np

from sc2jax.environment.pysc2.agents import base_agent
from sc2jax.environment.pysc2.lib import actions


class RandomAgent(base_agent.BaseAgent):
    """Picks one of `available_actions` and each argument at random (numpy's global
    generator, as PySC2's)."""

    def step(self, obs) -> actions.FunctionCall:
        super().step(obs)
        function_id = int(np.random.choice(obs.observation.available_actions))
        args = [[int(np.random.randint(0, size)) for size in arg.sizes]
                for arg in self.action_spec.functions[function_id].args]
        return actions.FunctionCall(function_id, args)
