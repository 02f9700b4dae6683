"""FindAndDefeatZerglings: three marines explore a fogged map for 25 zerglings.

From the map's script (reference/pysc2_facts.md §4): three preselected marines 1.0 from
the centre of region 1 at 210°, 330° and 90°. Zergling 1 at a distance U(8, 9) from the
centre in a random direction; zergling 2 in the ring 7.5-9.5 around it; zerglings 3-25
in (11, 13)-(53, 43) outside radius 10.5; each at least 5 from the nearest zergling.
+1 per zergling killed, -1 per marine lost. When all 25 are dead, 25 new ones appear in
region 1, at least 9 from every marine and 5 from each other (at the end of the agent
step; see `MiniGame.on_step`). The episode ends at the
timer or when every marine is dead. Fog of war is on and the camera is free.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.geometry import squared_length
from sc2jax.environment.lazy import lazy_where
from sc2jax.environment.minigames.base import (
    MiniGame,
    candidates,
    first_valid,
    flat_geometry,
    nearest_distance,
    pick_first_valid,
    uniform_in_rect,
)
from sc2jax.environment.state import Outcome, Owner, Units, place
from sc2jax.environment.units import UnitType

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


def _polar(center, radius, angle):
    return jnp.asarray(center) + radius * jnp.stack([jnp.cos(angle), jnp.sin(angle)], -1)


def _sample_sequence(key, first, sample, valid_from, tries: int = 48):
    """Places zerglings one after another: each is the first of `tries` draws that is
    valid against those already placed (float32[25, 2] with a mask). Zergling 0 is
    `first`.

    Every candidate is drawn before the sequence starts (`sample(i)(key)` for zergling i),
    so that the sequential part only checks them.
    """
    keys = jax.random.split(key, NUM_ZERGLINGS)
    points = jax.vmap(lambda i, k: candidates(k, sample(i), tries))(
        jnp.arange(NUM_ZERGLINGS), keys)  # [25, tries, 2]

    def body(carry, points_i):
        placed, mask, i = carry
        point = pick_first_valid(points_i, valid_from(points_i, placed, mask, i))
        point = jnp.where(i == 0, first, point)
        return (placed.at[i].set(point), mask.at[i].set(True), i + 1), None

    init = (jnp.zeros((NUM_ZERGLINGS, 2)), jnp.zeros(NUM_ZERGLINGS, bool), 0)
    (placed, _, _), _ = jax.lax.scan(body, init, points)
    return placed


def initial_zerglings(key):
    k_radius, k_angle, k_rest = jax.random.split(key, 3)
    first = _polar(CENTER, jax.random.uniform(k_radius, (), minval=8.0, maxval=9.0),
                   jax.random.uniform(k_angle, (), maxval=2 * np.pi))

    def sample(i):
        def draw(k):
            k1, k2 = jax.random.split(k)
            radius = jnp.sqrt(jax.random.uniform(k1, (), minval=RING[0] ** 2,
                                                 maxval=RING[1] ** 2))
            ring = _polar(CENTER, radius, jax.random.uniform(k2, (), maxval=2 * np.pi))
            return jnp.where(i == 1, ring, uniform_in_rect(k1, REGION_3))
        return draw

    def valid(points, placed, mask, i):
        spaced = nearest_distance(points, placed, mask) >= ZERGLING_SPACING
        outside = squared_length(points - jnp.asarray(CENTER)) >= REGION_3_HOLE ** 2
        return spaced & ((i == 1) | outside)

    return _sample_sequence(k_rest, first, sample, valid)


def respawned_zerglings(key, marine_pos, marine_alive):
    k_first, k_rest = jax.random.split(key)
    far = lambda p: nearest_distance(p, marine_pos, marine_alive) >= (  # noqa: E731
        RESPAWN_MARINE_DISTANCE)
    first = first_valid(k_first, lambda k: uniform_in_rect(k, REGION_1), far, tries=48)

    def valid(points, placed, mask, i):
        return far(points) & (nearest_distance(points, placed, mask) >= ZERGLING_SPACING)

    return _sample_sequence(k_rest, first, lambda i: lambda k: uniform_in_rect(k, REGION_1),
                            valid)


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
        key, sub = jax.random.split(state.key)
        respawn = ~units.alive[ZERGLINGS].any() & marine_alive.any()

        def respawned(op):
            units, next_tag, k = op
            return place(units, ZERGLINGS, UnitType.ZERGLING, Owner.ENEMY,
                         respawned_zerglings(k, units.pos[MARINES], units.alive[MARINES]),
                         next_tag)

        units, tag = lazy_where(respawn, respawned, (units, state.next_tag, sub),
                                (units, state.next_tag))
        return state.replace(units=units, key=key, next_tag=tag)
