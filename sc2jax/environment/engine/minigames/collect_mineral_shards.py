"""CollectMineralShards: two marines pick up 20 mineral shards; +1 per shard.

From the map's script (reference/pysc2_facts.md §4): two unselected marines at random
points of region 1; 20 shards at random points of region 3, each at least 2 from the
nearest marine (no spacing between shards). A marine touching a shard picks it up
(+100 minerals); the score is minerals / 100. When no shard is left, 20 new ones appear
by the same rule (at the end of the agent step; see `MiniGame.on_step`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.minigames.base import (
    MiniGame,
    first_valid,
    flat_geometry,
    nearest_distance,
    uniform_in_rect,
)
from sc2jax.environment.engine.rules.state import Owner, Units, place
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.engine.xla.lazy import lazy_where

REGION_1 = (22.0, 20.0, 44.0, 36.0)
REGION_3 = (23.0, 21.0, 43.0, 35.0)
NUM_SHARDS = 20
MIN_SHARD_DISTANCE = 2.0
MINERALS_PER_SHARD = 100
MARINES = np.arange(2)
SHARDS = np.arange(2, 2 + NUM_SHARDS)
PICKUP_DISTANCE = float(UNIT_DATA.radius[UnitType.MARINE] + UNIT_DATA.radius[
    UnitType.MINERAL_SHARD])


def _shard_positions(key, marine_pos, marine_alive):
    def one(k):
        return first_valid(
            k, lambda kk: uniform_in_rect(kk, REGION_3),
            lambda p: nearest_distance(p, marine_pos, marine_alive) >= MIN_SHARD_DISTANCE)

    return jax.vmap(one)(jax.random.split(key, NUM_SHARDS))


class CollectMineralShards(MiniGame):

    def __init__(self):
        super().__init__(name="CollectMineralShards", time_limit=120,
                         num_slots=2 + NUM_SHARDS, geometry=flat_geometry(REGION_1), fog=False,
                         camera=(33.0, 25.0),
                         unit_types=(UnitType.MARINE, UnitType.MINERAL_SHARD),
                         has_enemies=False, collider_slots=len(MARINES))

    def init(self, key):
        k_marines, k_shards = jax.random.split(key)
        marine_pos = uniform_in_rect(k_marines, REGION_1, (2,))
        units = Units.empty(self.num_slots)
        units, tag = place(units, MARINES, UnitType.MARINE, Owner.SELF, marine_pos, 0)
        shards = _shard_positions(k_shards, marine_pos, jnp.ones(2, bool))
        units, tag = place(units, SHARDS, UnitType.MINERAL_SHARD, Owner.NEUTRAL, shards, tag)
        return units, (), tag

    def on_loop(self, state, events):
        units = state.units
        marine_pos, marine_alive = units.pos[MARINES], units.alive[MARINES]
        shard_alive = units.alive[SHARDS]
        touching = nearest_distance(units.pos[SHARDS], marine_pos, marine_alive) <= (
            PICKUP_DISTANCE)
        picked = shard_alive & touching
        minerals = state.minerals + MINERALS_PER_SHARD * jnp.sum(picked)
        alive = units.alive.at[SHARDS[0]:SHARDS[-1] + 1].set(shard_alive & ~picked)
        units = units.replace(alive=alive)
        return state.replace(units=units, minerals=minerals,
                             score=minerals // MINERALS_PER_SHARD)

    def on_step(self, state):
        units = state.units
        key, sub = threefry.split(state.key)
        respawn = ~units.alive[SHARDS].any()

        def respawned(op):
            units, next_tag, k = op
            return place(units, SHARDS, UnitType.MINERAL_SHARD, Owner.NEUTRAL,
                         _shard_positions(k, units.pos[MARINES], units.alive[MARINES]),
                         next_tag)

        units, tag = lazy_where(respawn, respawned, (units, state.next_tag, sub),
                                (units, state.next_tag))
        return state.replace(units=units, next_tag=tag, key=key)
