"""Unit data: the simulator's unit types and their game stats, as arrays indexed by type.

The simulator numbers its unit types compactly (`UnitType`); `UNIT_DATA.sc2_id` maps them
to StarCraft II's unit ids (as in the `unit_type` layers). Terran types take their stats
from the Terran data table (`terran_data`, from the game API's data); the mini-games'
Zerg and neutral types from reference/pysc2_facts.md §7. Values are converted to game
loops: speeds in world units per loop, cooldowns in loops (16 loops per game second).
"""

from __future__ import annotations

import enum
import functools
from typing import NamedTuple

import numpy as np

from sc2jax.environment.engine import terran_data

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
    MULE = 14
    MARAUDER = 15
    REAPER = 16
    HELLION = 17
    SIEGE_TANK = 18
    SIEGE_TANK_SIEGED = 19
    MEDIVAC = 20
    VIKING_FIGHTER = 21
    VIKING_ASSAULT = 22
    COMMAND_CENTER_FLYING = 23
    ORBITAL_COMMAND = 24
    ORBITAL_COMMAND_FLYING = 25
    SUPPLY_DEPOT_LOWERED = 26
    BARRACKS_FLYING = 27
    FACTORY = 28
    FACTORY_FLYING = 29
    STARPORT = 30
    STARPORT_FLYING = 31
    BARRACKS_TECH_LAB = 32
    BARRACKS_REACTOR = 33
    FACTORY_TECH_LAB = 34
    FACTORY_REACTOR = 35
    STARPORT_TECH_LAB = 36
    STARPORT_REACTOR = 37
    ENGINEERING_BAY = 38
    BUNKER = 39


class Attribute(enum.IntFlag):
    LIGHT = 1
    ARMORED = 2
    BIOLOGICAL = 4
    MECHANICAL = 8
    STRUCTURE = 16


class Targets(enum.IntFlag):
    """What a weapon can hit."""

    GROUND = 1
    AIR = 2


@functools.cache
def terran_types() -> dict[str, UnitType]:
    """The Terran data table's name -> the type of that name ("SiegeTank" -> SIEGE_TANK),
    for the types the table holds."""
    names = {name.lower(): name for name in terran_data.table()["units"]}
    keys = {t: t.name.replace("_", "").lower() for t in UnitType}
    return {names[key]: t for t, key in keys.items() if key in names}


@functools.cache
def game_name(unit_type: UnitType) -> str | None:
    """The Terran data table's name of a type ("SIEGE_TANK" -> "SiegeTank"), or None for
    the types the table does not hold."""
    return {t: name for name, t in terran_types().items()}.get(unit_type)


class UnitData(NamedTuple):
    """Per-type stats; each field is an array of length `len(UnitType)`.

    Attributes:
      sc2_id: StarCraft II unit id.
      radius: collision radius, world units.
      speed: world units per game loop (0 for immobile units).
      max_health, max_shields, max_energy: vitals.
      start_energy: the energy a new unit has.
      armor: damage reduction per hit.
      damage: damage per hit (0: no weapon).
      bonus: extra damage per hit against targets with `bonus_attribute`.
      bonus_attribute: `Attribute` flag the bonus applies to (0: none).
      attacks: hits per attack (each reduced by armour).
      targets: `Targets` flags: what the weapon hits.
      cooldown: loops between attacks.
      range: weapon range, edge to edge, world units.
      sight: sight radius, world units.
      acquire: auto-acquisition range for idle and attack-moving units.
      attributes: `Attribute` flags.
      flying: the unit is in the air.
      town_hall: a landed Command Center or Orbital Command, where workers return cargo.
      walkable: a structure ground units walk over (a lowered Supply Depot).
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
    start_energy: np.ndarray
    armor: np.ndarray
    damage: np.ndarray
    bonus: np.ndarray
    bonus_attribute: np.ndarray
    attacks: np.ndarray
    targets: np.ndarray
    cooldown: np.ndarray
    range: np.ndarray
    sight: np.ndarray
    acquire: np.ndarray
    attributes: np.ndarray
    flying: np.ndarray
    town_hall: np.ndarray
    walkable: np.ndarray
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

# The mini-games' types that are not Terran, at Normal speed: speed in units per
# game-second, cooldown in game-seconds. Columns: sc2_id, radius, speed, health, armor,
# damage, bonus against Light, cooldown, range, sight, acquire, attributes, is_army,
# food, minerals, vespene.
_OTHERS = {
    UnitType.NONE: (0, 0.0, 0.0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0, 0, 0),
    UnitType.ZERGLING: (105, 0.375, 2.953, 35, 0, 5, 0, 0.696, 0.1, 8.0, 5.0, _L | _B,
                        1, 0.5, 25, 0),
    UnitType.ROACH: (110, 0.5, 2.25, 145, 1, 16, 0, 2.0, 4.0, 9.0, 5.0, _A | _B, 1, 2, 75, 25),
    UnitType.BANELING: (9, 0.375, 2.5, 30, 0, 20, 15, 0.833, 0.25, 8.0, 5.0, _B, 1, 0.5, 25, 25),
    UnitType.BEACON: (317, 1.25, 0.0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0, 0, 0),
    UnitType.MINERAL_SHARD: (1680, 0.375, 0.0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0, 0, 0),
    UnitType.MINERAL_FIELD: (341, 1.125, 0.0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, _S, 0, 0, 0, 0),
    UnitType.VESPENE_GEYSER: (342, 1.8125, 0.0, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, _S, 0, 0, 0, 0),
}

# Volatile Burst: splash radius from the unit's centre to a target's edge. Its damage is
# the table's (20, +15 against Light: 35 to a Marine in every game version).
_BURST = {UnitType.BANELING: 2.2}

# Resources: a MineralField holds 1800 minerals (Legacy of the Void), a geyser 2250 gas.
_CONTENTS = {UnitType.MINERAL_FIELD: 1800, UnitType.VESPENE_GEYSER: 2250}

# Placement footprints in cells (width, height) of the types the Terran table lacks.
_FOOTPRINT = {UnitType.MINERAL_FIELD: (2, 1), UnitType.VESPENE_GEYSER: (3, 3)}

# Auto-acquisition range (not in the API's data): the mini-games' units acquire within 5,
# workers never; the Terran table's other armed units within max(weapon range, 5).
ACQUIRE = 5.0
WORKERS = (UnitType.SCV, UnitType.MULE)

_ATTRIBUTES = {"Light": _L, "Armored": _A, "Biological": _B, "Mechanical": _M,
               "Structure": _S}
_TARGETS = {"Ground": Targets.GROUND, "Air": Targets.AIR, "Any": Targets.GROUND | Targets.AIR}


def _other_row(t: UnitType) -> dict:
    (sc2_id, radius, speed, health, armor, damage, bonus, cooldown, rng, sight, acquire,
     attributes, is_army, food, minerals, vespene) = _OTHERS[t]
    return dict(sc2_id=sc2_id, radius=radius, speed=speed, max_health=health, max_energy=0,
                start_energy=0, armor=armor, damage=damage, bonus=bonus,
                bonus_attribute=_L if bonus else 0, attacks=1 if damage else 0,
                targets=Targets.GROUND if damage else 0, cooldown=cooldown, range=rng,
                sight=sight, acquire=acquire, attributes=attributes, flying=False,
                town_hall=False, walkable=False, is_army=is_army, food=food, mineral_cost=minerals,
                vespene_cost=vespene,
                burst=_BURST.get(t, 0.0), contents=_CONTENTS.get(t, 0), build_time=0,
                supply=0, footprint=_FOOTPRINT.get(t, (0, 0)))


def _terran_row(t: UnitType, name: str) -> dict:
    row = terran_data.unit(name)
    weapons = row["weapons"]
    if len(weapons) > 1:
        raise ValueError(f"{name} has {len(weapons)} weapons; the engine models one")
    weapon = weapons[0] if weapons else None
    attributes = 0
    for attribute in row["attributes"]:
        attributes |= _ATTRIBUTES[attribute]
    armed = weapon is not None and t not in WORKERS
    return dict(
        sc2_id=row["sc2_id"], radius=row["radius"], speed=row["speed"],
        max_health=row["health"], max_energy=row["max_energy"],
        start_energy=row["start_energy"], armor=row["armor"],
        damage=weapon["damage"] if weapon else 0.0, bonus=weapon["bonus"] if weapon else 0.0,
        bonus_attribute=_ATTRIBUTES.get(weapon and weapon["bonus_attribute"], 0),
        attacks=weapon["attacks"] if weapon else 0,
        targets=_TARGETS[weapon["targets"]] if weapon else 0,
        cooldown=weapon["cooldown"] if weapon else 0.0,
        range=weapon["range"] if weapon else 0.0, sight=row["sight"],
        acquire=max(weapon["range"], ACQUIRE) if armed else 0.0, attributes=attributes,
        flying=row["flying"], is_army=row["food"] > 0 and t not in WORKERS, food=row["food"],
        town_hall="CommandCenter" in (name, row["tech_alias"]) and not row["flying"],
        walkable=name == "SupplyDepotLowered",
        mineral_cost=row["minerals"], vespene_cost=row["vespene"], burst=0.0, contents=0,
        build_time=row["build_time"], supply=row["supply"], footprint=tuple(row["footprint"]))


def _build() -> UnitData:
    rows = [_other_row(t) if game_name(t) is None else _terran_row(t, game_name(t))
            for t in UnitType]
    col = lambda name, dtype: np.asarray([r[name] for r in rows], dtype)  # noqa: E731
    f32 = lambda name: col(name, np.float32)  # noqa: E731
    i32 = lambda name: col(name, np.int32)  # noqa: E731
    return UnitData(
        sc2_id=i32("sc2_id"), radius=f32("radius"),
        speed=f32("speed") / LOOPS_PER_SECOND,
        max_health=f32("max_health"), max_shields=np.zeros(len(rows), np.float32),
        max_energy=f32("max_energy"), start_energy=f32("start_energy"), armor=f32("armor"),
        damage=f32("damage"), bonus=f32("bonus"), bonus_attribute=i32("bonus_attribute"),
        attacks=i32("attacks"), targets=i32("targets"),
        cooldown=f32("cooldown") * LOOPS_PER_SECOND,
        range=f32("range"), sight=f32("sight"), acquire=f32("acquire"),
        attributes=i32("attributes"), flying=col("flying", bool),
        town_hall=col("town_hall", bool), walkable=col("walkable", bool),
        is_army=col("is_army", bool),
        food=f32("food"), mineral_cost=i32("mineral_cost"), vespene_cost=i32("vespene_cost"),
        burst=f32("burst"), contents=f32("contents"), build_time=f32("build_time"),
        supply=f32("supply"), footprint=i32("footprint"))


UNIT_DATA = _build()
NUM_UNIT_TYPES = len(UnitType)
