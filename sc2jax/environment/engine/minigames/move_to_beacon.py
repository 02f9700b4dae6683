"""MoveToBeacon: one marine, one beacon; +1 each time the marine reaches the beacon.

From the map's script (reference/pysc2_facts.md §4): the marine appears unselected at a
random point of region 1; the beacon at a random point of region 3 (a rectangle minus a
circle of radius 4) at least 5 from the marine. Every game loop, if the marine is within
the 1.25-radius circle on the beacon, the score rises by 1 and the beacon moves again.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from sc2jax.environment.engine.minigames.base import (
    MiniGame,
    first_valid,
    flat_geometry,
    uniform_in_rect,
)
from sc2jax.environment.engine.rules.geometry import squared_length
from sc2jax.environment.engine.rules.state import Owner, Units, place
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.engine.xla.lazy import lazy_where

REGION_1 = (22.0, 20.0, 44.0, 36.0)
REGION_3 = (23.5, 21.5, 42.5, 34.5)
REGION_3_HOLE = ((33.0, 28.0), 4.0)
REWARD_RADIUS = 1.25
MIN_BEACON_DISTANCE = 5.0
MARINE, BEACON = 0, 1


def _beacon_position(key, marine_pos):
    (hx, hy), hr = REGION_3_HOLE

    def valid(points):
        outside_hole = squared_length(points - jnp.array([hx, hy])) >= hr * hr
        far = squared_length(points - marine_pos) >= MIN_BEACON_DISTANCE ** 2
        return outside_hole & far

    return first_valid(key, lambda k: uniform_in_rect(k, REGION_3), valid, tries=64)


class MoveToBeacon(MiniGame):

    def __init__(self):
        super().__init__(name="MoveToBeacon", time_limit=120, num_slots=2,
                         geometry=flat_geometry(REGION_1), fog=False,
                         camera=(33.0, 25.0),
                         unit_types=(UnitType.MARINE, UnitType.BEACON), has_enemies=False,
                         collider_slots=MARINE + 1)

    def init(self, key):
        k_marine, k_beacon = jax.random.split(key)
        marine_pos = uniform_in_rect(k_marine, REGION_1)
        units = Units.empty(self.num_slots)
        units, tag = place(units, jnp.array([MARINE]), UnitType.MARINE, Owner.SELF,
                           marine_pos[None], 0)
        beacon = _beacon_position(k_beacon, marine_pos)
        units, tag = place(units, jnp.array([BEACON]), UnitType.BEACON, Owner.NEUTRAL,
                           beacon[None], tag)
        return units, (), tag

    def on_loop(self, state, events):
        units = state.units
        marine = units.pos[MARINE]
        reached = units.alive[MARINE] & (
            squared_length(marine - units.pos[BEACON]) <= REWARD_RADIUS ** 2)
        key, sub = threefry.split(state.key)
        beacon = lazy_where(reached, lambda op: _beacon_position(*op), (sub, marine),
                            units.pos[BEACON])
        pos = units.pos.at[BEACON].set(beacon)
        return state.replace(units=units.replace(pos=pos), score=state.score + reached, key=key)
