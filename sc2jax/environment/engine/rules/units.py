"""Unit data: the simulator's unit types and their game stats, as arrays indexed by type.

The simulator numbers its unit types compactly (`UnitType`); `UNIT_DATA.sc2_id` maps them
to StarCraft II's unit ids (as in the `unit_type` layers). Stats are the game's values at
Normal speed (reference/pysc2_facts.md §7) converted to game loops: speeds in world units
per loop, cooldowns in loops (16 loops per game second).
"""

from __future__ import annotations

import enum
from typing import NamedTuple

import numpy as np

LOOPS_PER_SECOND = 16


class UnitType(enum.IntEnum):
    """The simulator's unit types. 0 is an empty slot."""

    NONE = 0
    MARINE = 1
    ZERGLING = 2
    ROACH = 3
    BANELING = 4
    SCV = 5
    BEACON = 6
    MINERAL_SHARD = 7
    MINERAL_FIELD = 8
    VESPENE_GEYSER = 9
    COMMAND_CENTER = 10
    SUPPLY_DEPOT = 11
    BARRACKS = 12
    REFINERY = 13


class Attribute(enum.IntFlag):
    LIGHT = 1
    ARMORED = 2
    BIOLOGICAL = 4
    MECHANICAL = 8
    STRUCTURE = 16


class UnitData(NamedTuple):
    """Per-type stats; each field is an array of length `len(UnitType)`.

    Attributes:
      sc2_id: StarCraft II unit id.
      radius: collision radius, world units.
      speed: world units per game loop (0 for immobile units).
      max_health, max_shields, max_energy: vitals.
      armor: damage reduction per hit.
      damage: damage per attack (0: no weapon).
      bonus_light: extra damage against Light targets.
      cooldown: loops between attacks.
      range: weapon range, edge to edge, world units.
      sight: sight radius, world units.
      acquire: auto-acquisition range for idle and attack-moving units.
      attributes: `Attribute` flags.
      is_army: counts for `select_army` and `army_count`.
      food: supply used.
      mineral_cost, vespene_cost: cost.
      burst: the radius of a suicide splash attack (0: none), world units. Such a unit
        (the Baneling's Volatile Burst) dies when it attacks, and also bursts when killed.
      contents: the resources a mineral field or geyser starts with (0: not a resource).
      build_time: loops to train the unit or construct the structure.
      supply: food the unit provides (the supply cap it adds once complete).
      footprint: int32[T, 2] the (width, height) in map cells a structure or resource
        blocks for placement (0 for units that block nothing).
    """

    sc2_id: np.ndarray
    radius: np.ndarray
    speed: np.ndarray
    max_health: np.ndarray
    max_shields: np.ndarray
    max_energy: np.ndarray
    armor: np.ndarray
    damage: np.ndarray
    bonus_light: np.ndarray
    cooldown: np.ndarray
    range: np.ndarray
    sight: np.ndarray
    acquire: np.ndarray
    attributes: np.ndarray
    is_army: np.ndarray
    food: np.ndarray
    mineral_cost: np.ndarray
    vespene_cost: np.ndarray
    burst: np.ndarray
    contents: np.ndarray
    build_time: np.ndarray
    supply: np.ndarray
    footprint: np.ndarray


_L, _A, _B, _M, _S = (Attribute.LIGHT, Attribute.ARMORED, Attribute.BIOLOGICAL,
                      Attribute.MECHANICAL, Attribute.STRUCTURE)

# Normal-speed values: speed in units per game-second, cooldown in game-seconds.
# Columns: sc2_id, radius, speed, health, shields, energy, armor, damage, bonus_light,
#          cooldown, range, sight, acquire, attributes, is_army, food, minerals, vespene.
_TABLE = {
    UnitType.NONE: (0, 0.0, 0.0, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0, 0, 0),
    UnitType.MARINE: (48, 0.375, 2.25, 45, 0, 0, 0, 6, 0, 0.8608, 5.0, 9.0, 5.0, _L | _B,
                      1, 1, 50, 0),
    UnitType.ZERGLING: (105, 0.375, 2.953, 35, 0, 0, 0, 5, 0, 0.696, 0.1, 8.0, 5.0, _L | _B,
                        1, 0.5, 25, 0),
    UnitType.ROACH: (110, 0.5, 2.25, 145, 0, 0, 1, 16, 0, 2.0, 4.0, 9.0, 5.0, _A | _B,
                     1, 2, 75, 25),
    UnitType.BANELING: (9, 0.375, 2.5, 30, 0, 0, 0, 20, 15, 0.833, 0.25, 8.0, 5.0, _B,
                        1, 0.5, 25, 25),
    UnitType.SCV: (45, 0.375, 2.8125, 45, 0, 0, 0, 5, 0, 1.5, 0.1, 8.0, 0.0, _L | _B | _M,
                   0, 1, 50, 0),
    UnitType.BEACON: (317, 1.25, 0.0, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0, 0, 0),
    UnitType.MINERAL_SHARD: (1680, 0.375, 0.0, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0,
                             0, 0, 0, 0),
    UnitType.MINERAL_FIELD: (341, 1.125, 0.0, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, _S,
                             0, 0, 0, 0),
    UnitType.VESPENE_GEYSER: (342, 1.8125, 0.0, 0, 0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, _S,
                              0, 0, 0, 0),
    UnitType.COMMAND_CENTER: (18, 2.75, 0.0, 1500, 0, 0, 1, 0, 0, 0.0, 0.0, 11.0, 0.0,
                              _A | _M | _S, 0, 0, 400, 0),
    UnitType.SUPPLY_DEPOT: (19, 1.25, 0.0, 400, 0, 0, 1, 0, 0, 0.0, 0.0, 9.0, 0.0,
                            _A | _M | _S, 0, 0, 100, 0),
    UnitType.BARRACKS: (21, 1.8125, 0.0, 1000, 0, 0, 1, 0, 0, 0.0, 0.0, 9.0, 0.0,
                        _A | _M | _S, 0, 0, 150, 0),
    UnitType.REFINERY: (20, 1.8125, 0.0, 500, 0, 0, 1, 0, 0, 0.0, 0.0, 9.0, 0.0,
                        _A | _M | _S, 0, 0, 75, 0),
}


# Volatile Burst: splash radius from the unit's centre to a target's edge. Its damage is
# the table's (20, +15 against Light: 35 to a Marine in every game version).
_BURST = {UnitType.BANELING: 2.2}

# Resources: a MineralField holds 1800 minerals (Legacy of the Void), a geyser 2250 gas.
_CONTENTS = {UnitType.MINERAL_FIELD: 1800, UnitType.VESPENE_GEYSER: 2250}

# Train and construction times in game loops (reference/pysc2_facts.md §7).
_BUILD_TIME = {UnitType.SCV: 272, UnitType.MARINE: 400, UnitType.SUPPLY_DEPOT: 480,
               UnitType.BARRACKS: 1040, UnitType.REFINERY: 480, UnitType.COMMAND_CENTER: 1600}

_SUPPLY = {UnitType.COMMAND_CENTER: 15, UnitType.SUPPLY_DEPOT: 8}

# Placement footprints in cells (width, height).
_FOOTPRINT = {UnitType.MINERAL_FIELD: (2, 1), UnitType.VESPENE_GEYSER: (3, 3),
              UnitType.COMMAND_CENTER: (5, 5), UnitType.SUPPLY_DEPOT: (2, 2),
              UnitType.BARRACKS: (3, 3), UnitType.REFINERY: (3, 3)}


def _build() -> UnitData:
    rows = [_TABLE[t] for t in UnitType]
    cols = list(zip(*rows))
    f32 = lambda c: np.asarray(c, np.float32)  # noqa: E731
    i32 = lambda c: np.asarray(c, np.int32)  # noqa: E731
    (sc2_id, radius, speed, health, shields, energy, armor, damage, bonus, cooldown, rng,
     sight, acquire, attributes, is_army, food, minerals, vespene) = cols
    return UnitData(
        sc2_id=i32(sc2_id), radius=f32(radius),
        speed=f32(speed) / LOOPS_PER_SECOND,
        max_health=f32(health), max_shields=f32(shields), max_energy=f32(energy),
        armor=f32(armor), damage=f32(damage), bonus_light=f32(bonus),
        cooldown=f32(cooldown) * LOOPS_PER_SECOND,
        range=f32(rng), sight=f32(sight), acquire=f32(acquire),
        attributes=i32([int(a) for a in attributes]), is_army=np.asarray(is_army, bool),
        food=f32(food), mineral_cost=i32(minerals), vespene_cost=i32(vespene),
        burst=f32([_BURST.get(t, 0.0) for t in UnitType]),
        contents=f32([_CONTENTS.get(t, 0) for t in UnitType]),
        build_time=f32([_BUILD_TIME.get(t, 0) for t in UnitType]),
        supply=f32([_SUPPLY.get(t, 0) for t in UnitType]),
        footprint=i32([_FOOTPRINT.get(t, (0, 0)) for t in UnitType]))


UNIT_DATA = _build()
NUM_UNIT_TYPES = len(UnitType)
