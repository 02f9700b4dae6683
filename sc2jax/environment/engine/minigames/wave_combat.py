"""DefeatRoaches and DefeatZerglingsAndBanelings: nine marines against waves of Zerg.

One script serves both maps (read from their MapScript.galaxy and Regions; see
reference/pysc2_facts.md §4):

- a random side: the marines at a random point of one spawn region, the enemies at a
  random point of the other;
- 9 preselected marines in a vertical line at y offsets 0, +1, -1, +2, -2, ... +4, -4;
- DefeatRoaches: 4 roaches at y offsets +0.5, +1.5, -0.5, -1.5. DefeatZerglingsAndBanelings:
  6 zerglings and 4 banelings created at one point (the game spreads them; here a fixed
  hexagonal packing);
- +10 per roach (+5 per zergling or baneling, exploding banelings included), -1 per marine;
- when every enemy is dead, a wave reset in the same game loop: each surviving marine is
  replaced by a new one (a new tag) that keeps its health, reinforcements join (+5 marines
  in DefeatRoaches, +4 in DefeatZerglingsAndBanelings), a side is drawn again, all marines
  line up (survivors first) and are selected, and a new wave of enemies appears;
- the end at the 120 s timer, or defeat when every marine is dead.

The enemies are created idle and fight as idle units do (`dynamics`): they acquire
marines that come within range, and turn on whoever attacks them or an ally near them.

The enemies occupy the first slots, one per `ENEMIES` entry, and the marines the
MARINE_SLOTS after them; a wave reset that would exceed those adds fewer reinforcements
(docs/fidelity.md). The marines fill their slots from the front, and for most of an
episode most are empty: the engine runs the game on the leading slots in use
(`slot_sizes`). So the script reads the marines' slots from the units it is given: all
the slots past the enemies'.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.minigames.base import MiniGame, flat_geometry, uniform_in_rect
from sc2jax.environment.engine.rules.state import Outcome, Owner, Units, place, place_where
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.engine.xla.lazy import lazy_where

REGION_1 = (22.0, 20.0, 44.0, 36.0)  # Playable Space (22.0002 in the map).
LEFT = (23.9748, 25.0637, 27.9787, 31.0483)  # Spawn Region Left (region 4).
RIGHT = (38.0207, 25.0427, 42.0351, 31.0773)  # Spawn Region Right (region 5).
CAMERA = (33.0, 25.0)  # centre(region 1) + 3 at 270 degrees.
START_MARINES = 9
MARINE_SLOTS = 64
# The marine slots the engine runs on. A middle size (32) would serve a policy that
# keeps 12-27 marines, for 60% more compilation of the step (docs/benchmarks.md).
MARINE_SIZES = (16, MARINE_SLOTS)

# Ten small units created at one point: the centre, a ring of six at one diameter
# (0.75), and three at sqrt(3) diameters.
_HEX = np.concatenate([
    np.zeros((1, 2)),
    0.75 * np.stack([np.cos(np.arange(6) * np.pi / 3), np.sin(np.arange(6) * np.pi / 3)], -1),
    0.75 * np.sqrt(3) * np.stack([np.cos(np.deg2rad([30, 150, 270])),
                                  np.sin(np.deg2rad([30, 150, 270]))], -1)]).astype(np.float32)


def lineup_offset(rank):
    """int32[...]: the y offset of the marine of 0-based `rank` in the script's line:
    0, +1, -1, +2, -2, ... (the script's (i / 2) * (1 - 2 * (i % 2)) for i = rank + 1)."""
    i = rank + 1
    return (i // 2) * (1 - 2 * (i % 2))


def draw_sides(key):
    """(marine point, enemy point), each float32[2]: one of the spawn regions at random
    for the marines, the other for the enemies."""
    k_side, k_left, k_right = jax.random.split(key, 3)
    left, right = uniform_in_rect(k_left, LEFT), uniform_in_rect(k_right, RIGHT)
    flip = jax.random.bernoulli(k_side)
    return jnp.where(flip, right, left), jnp.where(flip, left, right)


def lined_up(point, rank):
    """float32[M, 2]: marines of the given ranks (int32[M]) in a vertical line at `point`,
    kept inside the playable area."""
    pos = point + jnp.stack([jnp.zeros_like(rank), lineup_offset(rank)], -1).astype(jnp.float32)
    x0, y0, x1, y1 = REGION_1
    return jnp.clip(pos, jnp.array([x0, y0]), jnp.array([x1, y1]))


class WaveCombat(MiniGame):
    """The script shared by both maps; subclasses set the enemies and the numbers.

    Class attributes:
      ENEMIES: the enemy unit types, one per enemy slot, in creation order.
      OFFSETS: float32[E, 2] where each enemy is created, relative to the enemy point.
      KILL_REWARD: score per enemy death.
      REINFORCEMENTS: marines added at each wave reset.
    """

    ENEMIES: tuple[UnitType, ...] = ()
    OFFSETS: np.ndarray = np.zeros((0, 2), np.float32)
    KILL_REWARD = 0
    REINFORCEMENTS = 0

    def __init__(self, name):
        enemies = len(self.ENEMIES)
        super().__init__(name=name, time_limit=120, num_slots=enemies + MARINE_SLOTS,
                         geometry=flat_geometry(REGION_1), fog=False, camera=CAMERA,
                         unit_types=(UnitType.MARINE,) + tuple(sorted(set(self.ENEMIES))),
                         team_split=enemies,
                         slot_sizes=tuple(enemies + m for m in MARINE_SIZES),
                         spawn_room=self.REINFORCEMENTS)

    def _spawn_enemies(self, units: Units, point, next_tag):
        return place(units, jnp.arange(len(self.ENEMIES)), jnp.asarray(self.ENEMIES, jnp.int32),
                     Owner.ENEMY, point + jnp.asarray(self.OFFSETS), next_tag)

    def init(self, key):
        marine_point, enemy_point = draw_sides(key)
        units = Units.empty(self.num_slots)
        rank = jnp.arange(START_MARINES)
        units, tag = place(units, self.team_split + rank, UnitType.MARINE, Owner.SELF,
                           lined_up(marine_point, rank), 0, selected=True)
        units, tag = self._spawn_enemies(units, enemy_point, tag)
        return units, (), tag

    def wave_reset(self, state):
        """The next wave: survivors replaced (keeping health), reinforcements in the
        first free slots, a new side, the marines lined up and selected, new enemies.
        Only the marines' slots are written: the empty slots stay as they were. Written
        with selects, not scatters: it runs inside the game loop (`place_where`)."""
        key, sub = threefry.split(state.key)
        marine_point, enemy_point = draw_sides(sub)
        old, enemies = state.units, len(self.ENEMIES)
        survivors = old.alive[enemies:]
        free_rank = jnp.cumsum(~survivors) - 1
        fresh = ~survivors & (free_rank < self.REINFORCEMENTS)
        marines = survivors | fresh
        rank = jnp.where(survivors, jnp.cumsum(survivors) - 1, jnp.sum(survivors) + free_rank)
        # The enemies' tags follow the marines'.
        enemy_tag = state.next_tag + jnp.sum(marines, dtype=jnp.int32)
        per_side = lambda enemy, marine: jnp.concatenate([  # noqa: E731
            jnp.broadcast_to(jnp.asarray(enemy), (enemies,) + jnp.shape(marine)[1:]), marine])
        m = survivors.shape[0]
        units = place_where(
            old, per_side(True, marines),
            per_side(jnp.asarray(self.ENEMIES, jnp.int32),
                     jnp.full(m, UnitType.MARINE, jnp.int32)),
            per_side(Owner.ENEMY, jnp.full(m, Owner.SELF, jnp.int32)),
            jnp.concatenate([enemy_point + jnp.asarray(self.OFFSETS),
                             lined_up(marine_point, rank)]),
            per_side(enemy_tag + jnp.arange(enemies, dtype=jnp.int32), state.next_tag + rank),
            per_side(False, jnp.ones(m, bool)))
        units = units.replace(health=jnp.where(per_side(False, survivors), old.health,
                                               units.health))
        return state.replace(units=units, next_tag=enemy_tag + enemies, key=key)

    def on_loop(self, state, events):
        first = self.team_split
        kills = jnp.sum(events.died[:first])
        losses = jnp.sum(events.died[first:])
        units = state.units
        defeat = ~units.alive[first:].any()
        state = state.replace(score=state.score + self.KILL_REWARD * kills - losses,
                              outcome=jnp.where(defeat, int(Outcome.DEFEAT), state.outcome))
        wave = ~defeat & ~units.alive[:first].any()
        return lazy_where(wave, self.wave_reset, state, state)


class DefeatRoaches(WaveCombat):
    ENEMIES = (UnitType.ROACH,) * 4
    OFFSETS = np.array([[0.0, 0.5], [0.0, 1.5], [0.0, -0.5], [0.0, -1.5]], np.float32)
    KILL_REWARD = 10
    REINFORCEMENTS = 5

    def __init__(self):
        super().__init__("DefeatRoaches")


class DefeatZerglingsAndBanelings(WaveCombat):
    ENEMIES = (UnitType.ZERGLING,) * 6 + (UnitType.BANELING,) * 4
    OFFSETS = _HEX
    KILL_REWARD = 5
    REINFORCEMENTS = 4

    def __init__(self):
        super().__init__("DefeatZerglingsAndBanelings")
