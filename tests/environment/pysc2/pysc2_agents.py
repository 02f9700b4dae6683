"""Agents written against PySC2's own API, as its documentation and examples use it:
`pysc2.agents.base_agent`, `pysc2.lib.actions/features/units`, named observations.

This file imports `pysc2`, which is not installed: the tests load it with its import
lines changed to `sc2jax.environment.pysc2` and nothing else (`load_pysc2_agents`).
"""

import numpy as np
from pysc2.agents import base_agent
from pysc2.lib import actions, features, units

FUNCTIONS = actions.FUNCTIONS
SELF = features.PlayerRelative.SELF
NEUTRAL = features.PlayerRelative.NEUTRAL


def _points(mask):
    """The (x, y) screen points where `mask` holds."""
    ys, xs = mask.nonzero()
    return np.stack([xs, ys], axis=1)


class MoveToBeacon(base_agent.BaseAgent):
    """Selects the army, then moves it to the beacon's centre."""

    def step(self, obs):
        super().step(obs)
        if FUNCTIONS.Move_screen.id not in obs.observation.available_actions:
            return FUNCTIONS.select_army("select")
        beacon = _points(obs.observation.feature_screen.player_relative == NEUTRAL)
        if not len(beacon):
            return FUNCTIONS.no_op()
        return FUNCTIONS.Move_screen("now", beacon.mean(axis=0).astype(int))


class CollectMineralShards(base_agent.BaseAgent):
    """Moves both marines together to the shard nearest their centre, from the named
    `player_relative` layer."""

    def step(self, obs):
        super().step(obs)
        if FUNCTIONS.Move_screen.id not in obs.observation.available_actions:
            return FUNCTIONS.select_army("select")
        relative = obs.observation.feature_screen.player_relative
        shards, marines = _points(relative == NEUTRAL), _points(relative == SELF)
        if not len(shards) or not len(marines):
            return FUNCTIONS.no_op()
        distances = np.linalg.norm(shards - marines.mean(axis=0), axis=1)
        return FUNCTIONS.Move_screen("now", shards[np.argmin(distances)])


class CollectMineralShardsFeatureUnits(base_agent.BaseAgent):
    """Each marine in turn to the shard nearest it that the other is not closer to, from
    the `feature_units` rows and their named columns."""

    def reset(self):
        super().reset()
        self.turn = 0

    def step(self, obs):
        super().step(obs)
        unit_rows = obs.observation.feature_units
        marines = [u for u in unit_rows if u.alliance == SELF and
                   u.unit_type == units.Terran.Marine]
        shards = np.array([[u.x, u.y] for u in unit_rows if u.alliance == NEUTRAL])
        if len(marines) < 2 or not len(shards):
            return FUNCTIONS.no_op()
        marines.sort(key=lambda u: u.tag)
        marine, other = marines[self.turn % 2], marines[(self.turn + 1) % 2]
        if not marine.is_selected or other.is_selected:
            return FUNCTIONS.select_point("select", (marine.x, marine.y))
        self.turn += 1
        mine = np.linalg.norm(shards - [marine.x, marine.y], axis=1)
        theirs = np.linalg.norm(shards - [other.x, other.y], axis=1)
        ours = mine <= theirs
        choice = np.argmin(np.where(ours, mine, np.inf)) if ours.any() else np.argmin(mine)
        return FUNCTIONS.Move_screen("now", shards[choice])
