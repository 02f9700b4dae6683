"""FindAndDefeatZerglings: three marines explore a fogged map for 25 zerglings.

From the map's script (reference/pysc2_facts.md §4): three preselected marines 1.0 from
the centre of region 1 at 210°, 330° and 90°. Zergling 1 at a distance U(8, 9) from the
centre in a random direction; zergling 2 in the ring 7.5-9.5 around the centre;
zerglings 3-25 in (11, 13)-(53, 43) outside radius 10.5; each at least 5 from the
nearest zergling. +1 per zergling killed, -1 per marine lost. When all 25 are dead, 25
new ones appear in region 1, at least 9 from every marine and 5 from each other (at the
end of the agent step; see `MiniGame.on_step`). The episode ends at the timer or when
every marine is dead. Fog of war is on and the camera is free.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.minigames.base import (
    MiniGame,
    flat_geometry,
    nearest_distance,
    pick_first_valid,
    uniform_in_rect,
)
from sc2jax.environment.engine.rules.geometry import squared_length
from sc2jax.environment.engine.rules.state import Outcome, Owner, Units, place
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.engine.xla.lazy import lazy_where

REGION_1 = (10.0, 12.0, 54.0, 44.0)
CENTER = (32.0, 28.0)
RING = (7.5, 9.5)
REGION_3 = (11.0, 13.0, 53.0, 43.0)
REGION_3_HOLE = 10.5
NUM_MARINES = 3
NUM_ZERGLINGS = 25
MARINES = np.arange(NUM_MARINES)
ZERGLINGS = np.arange(NUM_MARINES, NUM_MARINES + NUM_ZERGLINGS)
ZERGLING_SPACING = 5.0
RESPAWN_MARINE_DISTANCE = 9.0
MARINE_ANGLES = np.deg2rad([210.0, 330.0, 90.0])
TRIES = 48
"""Candidates drawn for the second zergling (rejection sampling with a fixed budget: its
ring is mostly valid)."""
POOL = 2048
"""Draws for the zerglings placed in turn (`_place_in_turn`): at most 955 were used in
16,384 initial placements (median 148), 383 in as many respawns (docs/fidelity.md)."""


def _polar(center, radius, angle):
    return jnp.asarray(center) + radius * jnp.stack([jnp.cos(angle), jnp.sin(angle)], -1)


def _place_in_turn(pool, valid, placed):
    """Places the zerglings after `placed` one after another, as the script's retry loop
    does: each takes the next draws until one is valid against the rules and the
    zerglings placed before it.

    The draws are one stream, `pool`. A draw rejected for one zergling stays invalid for
    the next (the rules only add zerglings to keep away from), and a taken one is within
    0 of itself, so each zergling's draw is simply the first valid one in the pool, and
    placing it only marks the draws near it invalid.

    Args:
      pool: float32[P, 2] i.i.d. draws, in order.
      valid: bool[P] the draws valid against the rules and the zerglings in `placed`.
      placed: float32[K, 2] the zerglings placed before.

    Returns:
      float32[25, 2]. If the pool runs out (never seen: `POOL`), its last draw is taken.
    """
    def body(valid, _):
        point = pick_first_valid(pool, valid)
        return valid & _spaced(pool, point[None]), point

    _, rest = jax.lax.scan(body, valid, None, length=NUM_ZERGLINGS - len(placed))
    return jnp.concatenate([placed, rest])


def _spaced(points, placed):
    """bool[...]: points at least ZERGLING_SPACING from every zergling in `placed`."""
    return nearest_distance(points, placed, jnp.ones(len(placed), bool)) >= ZERGLING_SPACING


def initial_zerglings(key):
    k_radius, k_angle, k_ring, k_rest = jax.random.split(key, 4)
    first = _polar(CENTER, jax.random.uniform(k_radius, (), minval=8.0, maxval=9.0),
                   jax.random.uniform(k_angle, (), maxval=2 * np.pi))
    # The second zergling uniform in the ring (by area), 5 from the first.
    u = jax.random.uniform(k_ring, (TRIES, 2))
    radius = jnp.sqrt(RING[0] ** 2 + (RING[1] ** 2 - RING[0] ** 2) * u[:, 0])
    ring = _polar(CENTER, radius[:, None], 2 * np.pi * u[:, 1])
    second = pick_first_valid(ring, _spaced(ring, first[None]))
    # The rest in region 3, outside the hole around the centre.
    placed = jnp.stack([first, second])
    pool = uniform_in_rect(k_rest, REGION_3, (POOL,))
    outside = squared_length(pool - jnp.asarray(CENTER)) >= REGION_3_HOLE ** 2
    return _place_in_turn(pool, outside & _spaced(pool, placed), placed)


def respawned_zerglings(key, marine_pos, marine_alive):
    pool = uniform_in_rect(key, REGION_1, (POOL,))
    far = nearest_distance(pool, marine_pos, marine_alive) >= RESPAWN_MARINE_DISTANCE
    return _place_in_turn(pool, far, jnp.zeros((0, 2), jnp.float32))


class FindAndDefeatZerglings(MiniGame):

    def __init__(self):
        super().__init__(name="FindAndDefeatZerglings", time_limit=180,
                         num_slots=NUM_MARINES + NUM_ZERGLINGS,
                         geometry=flat_geometry(REGION_1), fog=True, camera=(32.0, 25.0),
                         unit_types=(UnitType.MARINE, UnitType.ZERGLING),
                         own_slots=NUM_MARINES, team_split=NUM_MARINES)

    def init(self, key):
        units = Units.empty(self.num_slots)
        marines = _polar(CENTER, 1.0, jnp.asarray(MARINE_ANGLES, jnp.float32))
        units, tag = place(units, MARINES, UnitType.MARINE, Owner.SELF, marines, 0,
                           selected=True)
        units, tag = place(units, ZERGLINGS, UnitType.ZERGLING, Owner.ENEMY,
                           initial_zerglings(key), tag)
        return units, (), tag

    def on_loop(self, state, events):
        units = state.units
        kills = jnp.sum(events.died[ZERGLINGS])
        losses = jnp.sum(events.died[MARINES])
        score = state.score + kills - losses
        defeat = ~units.alive[MARINES].any()
        outcome = jnp.where(defeat, int(Outcome.DEFEAT), state.outcome)
        return state.replace(score=score, outcome=outcome)

    def on_step(self, state):
        units = state.units
        marine_alive = units.alive[MARINES]
        key, sub = threefry.split(state.key)
        respawn = ~units.alive[ZERGLINGS].any() & marine_alive.any()

        def respawned(op):
            units, next_tag, k = op
            return place(units, ZERGLINGS, UnitType.ZERGLING, Owner.ENEMY,
                         respawned_zerglings(k, units.pos[MARINES], units.alive[MARINES]),
                         next_tag)

        units, tag = lazy_where(respawn, respawned, (units, state.next_tag, sub),
                                (units, state.next_tag))
        return state.replace(units=units, key=key, next_tag=tag)
