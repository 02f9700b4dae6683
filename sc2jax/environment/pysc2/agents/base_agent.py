"""PySC2's `pysc2.agents.base_agent`: the agent every PySC2 agent subclasses."""

from __future__ import annotations

from sc2jax.environment.pysc2.lib import actions


class BaseAgent:
    """Counts steps, episodes and reward, and does nothing (`no_op`).

    Attributes:
      reward: the reward summed over every step so far.
      episodes: episodes started.
      steps: steps taken.
      obs_spec, action_spec: this agent's specs, from `setup`.
    """

    def __init__(self):
        self.reward = 0
        self.episodes = 0
        self.steps = 0
        self.obs_spec = None
        self.action_spec = None

    def setup(self, obs_spec, action_spec) -> None:
        self.obs_spec = obs_spec
        self.action_spec = action_spec

    def reset(self) -> None:
        self.episodes += 1

    def step(self, obs) -> actions.FunctionCall:
        self.steps += 1
        self.reward += obs.reward
        return actions.FunctionCall(actions.FUNCTIONS.no_op.id, [])
