"""Research: the player's upgrades and what they do to its units.

Each research is queued at its structure (a Barracks Tech Lab or an Engineering Bay) as
a unit is trained (`production`: paid when queued, refunded when cancelled, in its
research time), once per player: a research done or in a queue cannot be queued again.
Costs, times and where each is researched come from the Terran data table
(`terran_data`); what each does is the game's (Liquipedia, Legacy of the Void 5.0):

- **Stimpack** (`Effect_Stim_quick`): a Marine pays 10 health, a Marauder 20 (only with
  more health than that), to move and fire 50% faster for 11 seconds at Faster speed
  (`STIM_LOOPS`).
- **Combat Shield**: Marines have 10 more health, at once and when trained.
- **Concussive Shells**: a Marauder's hit slows its target's movement by 50% for 1.07
  seconds at Faster speed (`SLOW_LOOPS`).
- **Infantry Weapons Level 1**: +1 damage per attack to Marines and Reapers (each of the
  Reaper's two shots), +1 (+1 against Armored) to Marauders.
- **Infantry Armor Level 1**: +1 armour to Marines, Marauders and Reapers.

A queue holds items: unit types below `FIRST`, and research r as `FIRST + r`
(`item`); `COST`, `TIME` and `AT` describe the researches.
"""

from __future__ import annotations

import enum
import functools

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine import terran_data
from sc2jax.environment.engine.rules import commands
from sc2jax.environment.engine.rules.state import NO_TARGET, Owner, Units, targeted_by
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType, terran_types
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionType, function_for_ability


class Research(enum.IntEnum):
    """The researches the simulator has."""

    STIMPACK = 0
    COMBAT_SHIELD = 1
    CONCUSSIVE_SHELLS = 2
    INFANTRY_WEAPONS_1 = 3
    INFANTRY_ARMOR_1 = 4


GAME_NAME = {Research.STIMPACK: "Stimpack", Research.COMBAT_SHIELD: "ShieldWall",
             Research.CONCUSSIVE_SHELLS: "PunisherGrenades",
             Research.INFANTRY_WEAPONS_1: "TerranInfantryWeaponsLevel1",
             Research.INFANTRY_ARMOR_1: "TerranInfantryArmorsLevel1"}
"""Each research's name in the game's data (and the Terran data table)."""

FUNCTION = {Research.STIMPACK: "Research_Stimpack_quick",
            Research.COMBAT_SHIELD: "Research_CombatShield_quick",
            Research.CONCUSSIVE_SHELLS: "Research_ConcussiveShells_quick",
            Research.INFANTRY_WEAPONS_1: "Research_TerranInfantryWeaponsLevel1_quick",
            Research.INFANTRY_ARMOR_1: "Research_TerranInfantryArmorLevel1_quick"}
"""Each research's PySC2 function (its specific one; the card shows `BUTTON`'s)."""
BUTTON = {r: FUNCTIONS[function_for_ability(FUNCTIONS[name].ability_id,
                                            FunctionType.cmd_quick)].name
          for r, name in FUNCTION.items()}
"""Each research's function as PySC2 shows it, the general one where there is one
(`Research_TerranInfantryWeapons_quick`)."""

FIRST = len(UnitType)
"""The queue item of research r is `FIRST + r`."""
NUM_ITEMS = FIRST + len(Research)


def item(research) -> int:
    """The queue item of a `Research`."""
    return FIRST + int(research)


def _tables():
    rows = terran_data.table()["upgrades"]
    types = terran_types()
    cost = np.zeros((len(Research), 2), np.int32)
    time = np.zeros(len(Research), np.float32)
    at = np.zeros(len(Research), np.int32)
    upgrade_id = np.zeros(len(Research), np.int32)
    for r, name in GAME_NAME.items():
        row = rows[name]
        cost[r] = row["minerals"], row["vespene"]
        time[r] = row["research_time"]
        at[r] = types[row["researched_at"]]
        upgrade_id[r] = row["upgrade_id"]
    return cost, time, at, upgrade_id


COST, TIME, AT, UPGRADE_ID = _tables()
"""COST: int32[R, 2] minerals and vespene. TIME: float32[R] game loops. AT: int32[R] the
`UnitType` that researches each. UPGRADE_ID: int32[R] the game's upgrade id (the
observation's `upgrades`)."""

STIM_LOOPS = 246.0
"""Stimpack's duration: 11 seconds at Faster speed (22.4 game loops a second)."""
STIM_HEALTH = np.zeros(len(UnitType), np.float32)
"""float32[T]: the health a stim costs each type (0: it cannot stim)."""
STIM_HEALTH[[UnitType.MARINE, UnitType.MARAUDER]] = 10.0, 20.0
STIM_RATE = 1.5
"""A stimmed unit's movement speed and attack rate, times the usual."""
SLOW_LOOPS = 24.0
"""Concussive Shells' slow: 1.07 seconds at Faster speed."""
SLOW_FACTOR = 0.5
SHIELD_HEALTH = np.zeros(len(UnitType), np.float32)
"""float32[T]: the health Combat Shield adds to each type."""
SHIELD_HEALTH[UnitType.MARINE] = 10.0
INFANTRY = (UnitType.MARINE, UnitType.MARAUDER, UnitType.REAPER)
"""The units Infantry Weapons and Armor upgrade."""
WEAPON_STEP = np.zeros((len(UnitType), 2), np.float32)
"""float32[T, 2]: Infantry Weapons Level 1's damage and bonus per hit for each type.
The table splits the Marauder's 10 (+10 against Armored) into two hits of 5 (+5); its
+1 (+1) is split the same way."""
WEAPON_STEP[UnitType.MARINE] = 1.0, 0.0
WEAPON_STEP[UnitType.REAPER] = 1.0, 0.0
WEAPON_STEP[UnitType.MARAUDER] = (np.array([1.0, 1.0])
                                  / UNIT_DATA.attacks[UnitType.MARAUDER])


def queued(queue, where) -> jax.Array:
    """bool[R]: the researches among the queue items int32[N, B] `queue` where bool[N, B]
    (or bool[N, 1]) `where` holds."""
    items = FIRST + jnp.arange(len(Research), dtype=jnp.int32)
    return jnp.any(where[..., None] & (queue[..., None] == items), axis=(0, 1))


def done(researched, research) -> jax.Array:
    """bool: `research` is in bool[R] `researched`."""
    return jnp.asarray(researched)[int(research)]


def has(units: Units, researched, research) -> jax.Array:
    """bool[N]: the units whose owner has `research`, from `researched`: bool[R] the
    player's (`Owner.SELF`), or bool[P, R] each player's (the player's, then on
    two-player maps the other's, `Owner.ENEMY`)."""
    rows = jnp.atleast_2d(jnp.asarray(researched))
    owners = (Owner.SELF, Owner.ENEMY)[:rows.shape[0]]
    return functools.reduce(jnp.logical_or, [
        (units.owner == owner) & rows[p, int(research)] for p, owner in enumerate(owners)])


def unit_rows(data, units: Units, researched):
    """The per-slot unit stats `data` (UnitData rows of `units.type`) with the players'
    research (`researched`, as in `has`) and the units' stims and slows applied: damage,
    bonus and armour of the upgraded infantry, and the speed and cooldown of stimmed
    and slowed units."""
    weapons = has(units, researched, Research.INFANTRY_WEAPONS_1)
    armored = has(units, researched, Research.INFANTRY_ARMOR_1)
    infantry = jnp.isin(units.type, jnp.asarray(INFANTRY, jnp.int32))
    step = jnp.asarray(WEAPON_STEP)[units.type]
    stimmed = units.stim > 0
    speed = jnp.where(stimmed, data.speed * STIM_RATE, data.speed)
    return data._replace(
        damage=data.damage + jnp.where(weapons, step[:, 0], 0.0),
        bonus=data.bonus + jnp.where(weapons, step[:, 1], 0.0),
        armor=data.armor + jnp.where(armored & infantry, 1.0, 0.0),
        speed=jnp.where(units.slow > 0, speed * SLOW_FACTOR, speed),
        cooldown=jnp.where(stimmed, data.cooldown / STIM_RATE, data.cooldown),
        max_health=max_health(units, researched))


def max_health(units: Units, researched):
    """float32[N]: each unit's most health, with its owner's Combat Shield
    (`researched` as in `has`)."""
    shield = has(units, researched, Research.COMBAT_SHIELD)
    return (jnp.asarray(UNIT_DATA.max_health)[units.type]
            + jnp.where(shield, jnp.asarray(SHIELD_HEALTH)[units.type], 0.0))


def stim(units: Units, researched):
    """`Effect_Stim_quick`: the player's selected complete Marines and Marauders with
    more health than a stim costs pay it and are stimmed for `STIM_LOOPS` (again if
    stimmed). Needs Stimpack (the button shows only then).

    Returns:
      (units, ok bool: any stimmed).
    """
    cost = jnp.asarray(STIM_HEALTH)[units.type]
    stims = (commands.commandable(units) & units.complete & (cost > 0)
             & (units.health > cost) & done(researched, Research.STIMPACK))
    return units.replace(health=jnp.where(stims, units.health - cost, units.health),
                         stim=jnp.where(stims, STIM_LOOPS, units.stim)), stims.any()


def timers(units: Units, researched, hits, target):
    """The units' stims and slows after a game loop: a loop shorter, and the targets of
    the Marauders that hit this loop slowed anew where their owner has Concussive Shells.

    Args:
      units: the units at the loop's start.
      researched: the players' research, as in `has`.
      hits: bool[N] the units whose attack hit this loop.
      target: int32[N] the slot each unit attacked (read where `hits`).

    Returns:
      (stim float32[N], slow float32[N]).
    """
    concussive = (hits & (units.type == UnitType.MARAUDER)
                  & has(units, researched, Research.CONCUSSIVE_SHELLS))
    slowed = targeted_by(jnp.where(concussive, target, NO_TARGET), units.num_slots).any(axis=0)
    return (jnp.maximum(units.stim - 1.0, 0.0),
            jnp.where(slowed, SLOW_LOOPS, jnp.maximum(units.slow - 1.0, 0.0)))


def shield_health(units: Units, researched, finished, created):
    """The units after a game loop's production, with Combat Shield's health added to
    the Marines of a player whose Combat Shield finished this loop (`finished`), and to
    the ones created this loop (bool[N] `created`) where it is done (`researched`, after
    the loop); both as in `has`."""
    gains = units.alive & jnp.where(created, has(units, researched, Research.COMBAT_SHIELD),
                                    has(units, finished, Research.COMBAT_SHIELD))
    return units.replace(
        health=units.health + jnp.where(gains, jnp.asarray(SHIELD_HEALTH)[units.type], 0.0))


def value(researched):
    """int32: the minerals and vespene the research done (bool[R]) cost."""
    return jnp.sum(jnp.where(jnp.asarray(researched), jnp.asarray(COST.sum(axis=1)), 0))
