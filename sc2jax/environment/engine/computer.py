"""The simulator's built-in AI: a scripted Terran player for melee maps, at a difficulty.

`command(state, level, home, enemy_home, natural, buildable)` is a pure, jittable policy: from
the game as the computer sees it (`players.mirror` of the agent's state) it returns one
`actions.RawCommand` an agent step, the first of these jobs that applies:

1. **retreat**: an attack whose army fell below `Level.retreat` of a wave goes home;
2. **defence**: idle army units attack enemies within `DEFENCE_RADIUS` of home (or of
   the natural expansion, once it stands);
3. **mining**: idle SCVs gather at the base (home, or the natural expansion once its
   Command Center stands) with fewer of them per mineral field; once the natural
   stands, SCVs beyond 2 a field at home move there;
4. **supply**: a Supply Depot when the free supply is below `Level.supply_margin`, or
   there is none (Barracks need one), and none is being built;
5. **expansion** (`Level.expand_at`): a Command Center at the natural expansion (the
   base nearest home, `Melee.naturals`); from then until an SCV is on its way, the
   computer saves its minerals for it (no tech, army, Barracks or gas);
6. **workers**: an SCV from each idle Command Center, up to `Level.workers`;
7. **attack**: once `Level.first_attack` game loops have passed and its army numbers a
   wave (`Level.wave`), all of it attack-moves on the enemy structure nearest it (the
   computer knows where structures stand, as the game's AI knows the start
   locations), or the enemy's start location when it knows none; while an attack
   lasts, new units join it;
8. **tech** (`Level.tech`): a Tech Lab on the first Barracks, and Stimpack there;
9. **army**: a Marine (a Marauder at a Tech Lab) at an idle Barracks;
10. **Barracks** up to `Level.barracks`, once a Supply Depot stands, and more (up to
   `MAX_BARRACKS`) while its minerals reach `Level.bank`;
11. **gas**: Refineries up to `Level.refineries`, and 3 SCVs to each;
12. **scouting** (`Level.scout_at`): one SCV walks to the enemy's start location.

Structures go on the first site, nearest home first, of a fixed ring around it away
from the mineral line, where the structure fits (`production.placement`); a Barracks'
site also leaves its add-on room. A level acts on every `Level.period`-th agent step
(its reaction time); the stronger levels expand, train more workers, build more
Barracks, tech, attack with more and retreat.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.actions import RawCommand
from sc2jax.environment.engine.rules import production, research
from sc2jax.environment.engine.rules.geometry import squared_length
from sc2jax.environment.engine.rules.state import NO_TARGET, EnvState, Order, Owner
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.environment.interface.players import Difficulty

F = FUNCTIONS
DEFENCE_RADIUS = 25.0
"""World units from home within which enemies draw the computer's idle army."""
GAS_WORKERS = 3
FIELD_WORKERS = 2
"""SCVs a mineral field takes before a base counts as saturated."""
BASE_RADIUS = 12.0
"""World units from a Command Center site within which a base's mineral fields lie."""
MAX_BARRACKS = 8


class Level(NamedTuple):
    """What a difficulty builds and how it fights.

    Attributes:
      workers: SCVs to train up to.
      barracks: Barracks to build.
      refineries: Refineries to build (each gets `GAS_WORKERS` SCVs).
      tech: a Tech Lab on a Barracks, Marauders there, and Stimpack.
      supply_margin: free supply under which a Supply Depot is started.
      wave: idle army units that launch an attack.
      first_attack: game loops before the first attack.
      retreat: the share of a wave under which an attacking army goes home (0: never).
      period: the computer acts on every period-th agent step.
      scout_at: the game loop an SCV scouts at (0: never).
      bank: minerals at which it builds Barracks beyond `barracks`, up to
        `MAX_BARRACKS` (0: never; the weak levels float their money).
      expand_at: the game loop from which it takes its natural expansion (0: never).
    """

    workers: int
    barracks: int
    refineries: int
    tech: bool
    supply_margin: int
    wave: int
    first_attack: int
    retreat: float
    period: int
    scout_at: int
    bank: int
    expand_at: int


LOOPS_PER_MINUTE = 22.4 * 60
LEVELS = {
    Difficulty.very_easy: Level(workers=12, barracks=1, refineries=0, tech=False,
                                supply_margin=1, wave=4, first_attack=int(8 * LOOPS_PER_MINUTE),
                                retreat=0.0, period=6, scout_at=0, bank=0,
                                expand_at=0),
    Difficulty.easy: Level(workers=14, barracks=2, refineries=0, tech=False, supply_margin=2,
                           wave=6, first_attack=int(7 * LOOPS_PER_MINUTE), retreat=0.0,
                           period=4, scout_at=int(2 * LOOPS_PER_MINUTE), bank=0,
                           expand_at=0),
    Difficulty.medium: Level(workers=30, barracks=3, refineries=1, tech=False,
                             supply_margin=4, wave=10, first_attack=int(6 * LOOPS_PER_MINUTE),
                             retreat=0.3, period=2, scout_at=int(2 * LOOPS_PER_MINUTE),
                             bank=600, expand_at=int(5 * LOOPS_PER_MINUTE)),
    Difficulty.hard: Level(workers=38, barracks=4, refineries=2, tech=True, supply_margin=6,
                           wave=16, first_attack=int(7 * LOOPS_PER_MINUTE), retreat=0.4,
                           period=1, scout_at=int(1.5 * LOOPS_PER_MINUTE), bank=400,
                           expand_at=int(4 * LOOPS_PER_MINUTE)),
}
"""The levels the simulator's computer plays (`Difficulty`'s first, third and fifth are
VeryEasy, Medium and Hard)."""


def opponent(race: str, difficulty, build: str = "random") -> Difficulty:
    """The difficulty the simulator's computer plays for an opponent asked for as a race
    name, a difficulty (a `Difficulty`, its number or its name) and a build name: a
    Terran (or "random", which draws Terran, the one race it plays) of build "random".

    Raises:
      ValueError: for another race or build, or a difficulty it does not play.
    """
    if race not in ("terran", "random") or build != "random":
        raise ValueError(f"the simulator's computer is a Terran (race 'terran' or 'random') "
                         f"of build 'random'; got race {race!r}, build {build!r}")
    return played(difficulty)


def played(difficulty) -> Difficulty:
    """The `Difficulty` of a difficulty the computer plays (a `Difficulty`, its number or
    its name).

    Raises:
      ValueError: for a difficulty it does not play, naming those it does.
    """
    found = None
    if isinstance(difficulty, str):
        found = Difficulty.__members__.get(difficulty)
    elif isinstance(difficulty, (int, np.integer)) and not isinstance(difficulty, bool):
        found = int(difficulty)
    if found not in LEVELS:
        names = [d.name for d in LEVELS]
        raise ValueError(f"the simulator's computer plays difficulties {names}, got "
                         f"{difficulty!r}")
    return Difficulty(found)


def level(difficulty) -> Level:
    """The `Level` of a difficulty (as `played` takes it)."""
    return LEVELS[played(difficulty)]


def _ring(radius_min: float, radius_max: float, spacing: float) -> np.ndarray:
    """float32[K, 2]: grid offsets whose length is in [radius_min, radius_max], nearest
    first."""
    span = np.arange(-radius_max, radius_max + spacing, spacing)
    grid = np.stack(np.meshgrid(span, span), -1).reshape(-1, 2)
    length = np.linalg.norm(grid, axis=-1)
    grid = grid[(length >= radius_min) & (length <= radius_max)]
    return grid[np.argsort(np.linalg.norm(grid, axis=-1), kind="stable")].astype(np.float32)


SITES = _ring(6.0, 16.0, 2.0)
"""Candidate offsets from home of the structures the computer builds."""


def _site(state: EnvState, buildable, unit_type, home, away, addon: bool = False):
    """(bool any fits, float32[2] the first fitting site): of `SITES` around `home` on
    the side away from the mineral line (`away`: float32[2] unit direction)."""
    units = state.units
    points = home + jnp.asarray(SITES)
    ahead = jnp.asarray(SITES) @ away >= 0.0

    def fits(point):
        site = production.snap(unit_type, point)
        ok = production.placement(units, buildable, unit_type, site) == 0
        if addon:
            lab = jnp.int32(UnitType.BARRACKS_TECH_LAB)
            ok = ok & (production.placement(
                units, buildable, lab,
                site + jnp.asarray(production.ADDON_OFFSET, jnp.float32)) == 0)
        return ok, site

    ok, sites = jax.vmap(fits)(points)
    ok = ok & ahead
    first = jnp.argmax(ok)
    return ok.any(), sites[first]


def _nearest(mask, pos, point):
    """int32: the slot where bool[N] `mask` holds nearest `point` (float32[2])."""
    return jnp.argmin(jnp.where(mask, squared_length(pos - point), jnp.inf)).astype(jnp.int32)


def command(state: EnvState, lvl: Level, home, enemy_home, natural,
            buildable) -> RawCommand:
    """The computer's command this agent step (no_op on the steps between its
    `Level.period`).

    Args:
      state: the game as the computer sees it (it is `Owner.SELF`).
      lvl: its `Level`.
      home: float32[2] its start location.
      enemy_home: float32[2] the enemy's start location.
      natural: float32[2] its natural expansion's Command Center site.
      buildable: bool[H, W] the map's buildable cells.
    """
    units = state.units
    n = units.num_slots
    types = units.type
    mine = units.alive & (units.owner == Owner.SELF)
    complete = units.complete
    idle = units.orders[:, 0] == Order.NONE
    scv = mine & (types == UnitType.SCV) & complete
    army = mine & jnp.asarray(UNIT_DATA.is_army)[types] & complete
    enemy = units.alive & (units.owner == Owner.ENEMY)
    ordered = lambda t: scv & jnp.any((units.orders == Order.BUILD)  # noqa: E731
                                      & (units.order_type == t), axis=1)
    kind_count = lambda t: jnp.sum((mine & (types == t)) | ordered(t))  # noqa: E731
    fields = units.alive & (types == UnitType.MINERAL_FIELD) & (units.contents > 0)
    home_fields = fields & (squared_length(units.pos - home) < BASE_RADIUS ** 2)
    centre = jnp.sum(jnp.where(home_fields[:, None], units.pos, 0.0), 0) / jnp.maximum(
        jnp.sum(home_fields), 1)
    towards = centre - home
    away = -towards / jnp.maximum(jnp.sqrt(squared_length(towards)), 1e-3)
    minerals, vespene = state.minerals, state.vespene
    free_supply = production.food_cap(units) - production.food_used(units)
    gathered = units.order_unit[:, 0]
    safe_gathered = jnp.clip(gathered, 0, n - 1)
    mining = (scv & (units.orders[:, 0] == Order.GATHER) & (units.cargo == 0)
              & (types[safe_gathered] == UnitType.MINERAL_FIELD))
    town_type = jnp.isin(types, jnp.asarray([UnitType.COMMAND_CENTER,
                                             UnitType.ORBITAL_COMMAND], jnp.int32))
    at_natural = mine & town_type & (squared_length(units.pos - natural) < 1.0)
    expanded = jnp.any(at_natural & complete)
    natural_fields = fields & (squared_length(units.pos - natural) < BASE_RADIUS ** 2)
    # Each base's mineral SCVs (a harvester's field is its `home`), per field.
    harvesting = scv & ((units.orders[:, 0] == Order.GATHER) | (units.orders[:, 0] == Order.RETURN))
    field_of = jnp.clip(units.home, 0, n - 1)
    home_miners = harvesting & home_fields[field_of] & (units.home >= 0)
    natural_miners = harvesting & natural_fields[field_of] & (units.home >= 0)
    room = lambda miners, at: FIELD_WORKERS * jnp.sum(at) - jnp.sum(miners)  # noqa: E731
    to_natural = expanded & natural_fields.any() & (
        jnp.sum(natural_miners) * jnp.maximum(jnp.sum(home_fields), 1)
        < jnp.sum(home_miners) * jnp.maximum(jnp.sum(natural_fields), 1))
    base = jnp.where(to_natural, natural, home)
    field = _nearest(fields, units.pos, base)

    def one(slot):
        return jnp.arange(n) == slot

    jobs = []  # (applies, function, units, point, target)

    # 1. Retreat (from an attack on the enemy structure nearest the army).
    enemy_structures = enemy & jnp.asarray((UNIT_DATA.food == 0)
                                           & (UNIT_DATA.max_health > 0))[types]
    centroid = jnp.sum(jnp.where(army[:, None], units.pos, 0.0), 0) / jnp.maximum(
        jnp.sum(army), 1)
    target = jnp.where(enemy_structures.any(),
                       units.pos[_nearest(enemy_structures, units.pos, centroid)], enemy_home)
    attacking = army & (units.orders[:, 0] == Order.ATTACK_MOVE) & (
        squared_length(units.order_pos[:, 0] - target) < 1.0)
    retreat = (lvl.retreat > 0) & attacking.any() & (
        jnp.sum(army) < lvl.retreat * lvl.wave)
    jobs.append((retreat, F.Move_screen.id, army, home, NO_TARGET))
    # 2. Defence.
    near = enemy & ((squared_length(units.pos - home) < DEFENCE_RADIUS ** 2)
                    | (expanded & (squared_length(units.pos - natural) < DEFENCE_RADIUS ** 2)))
    intruder = _nearest(near, units.pos, home)
    jobs.append((near.any() & (army & idle).any(), F.Attack_screen.id, army & idle,
                 units.pos[intruder], NO_TARGET))
    # 3. Idle SCVs mine.
    jobs.append((fields.any() & (scv & idle).any(), F.Harvest_Gather_screen.id, scv & idle,
                 units.pos[field], field))
    moves = jnp.minimum(-room(home_miners, home_fields), room(natural_miners, natural_fields))
    movers = home_miners & (jnp.cumsum(home_miners) <= moves)
    natural_field = _nearest(natural_fields, units.pos, natural)
    jobs.append((expanded & (moves > 0), F.Harvest_Gather_screen.id, movers,
                 units.pos[natural_field], natural_field))
    # 4. Supply.
    depot_building = jnp.any(mine & (types == UnitType.SUPPLY_DEPOT) & ~complete) | jnp.any(
        ordered(UnitType.SUPPLY_DEPOT))
    depot_fits, depot_site = _site(state, buildable, UnitType.SUPPLY_DEPOT, home, away)
    builder = lambda site: one(_nearest(mining, units.pos, site))  # noqa: E731
    any_depot = jnp.any(mine & (jnp.asarray(production.COUNTS_AS)[types]
                                == UnitType.SUPPLY_DEPOT))
    short_supply = (free_supply < lvl.supply_margin) | ~any_depot  # Barracks need one.
    jobs.append((short_supply & (production.food_cap(units) < 200) & ~depot_building
                 & (minerals >= 100) & depot_fits & mining.any(),
                 F.Build_SupplyDepot_screen.id, builder(depot_site), depot_site, NO_TARGET))
    # 5. Expansion, saving for it once due.
    expanding = jnp.any(at_natural) | jnp.any(ordered(UnitType.COMMAND_CENTER))
    cc_fits = production.placement(units, buildable, jnp.int32(UnitType.COMMAND_CENTER),
                                   natural) == 0
    saving = (lvl.expand_at > 0) & (state.game_loop >= lvl.expand_at) & ~expanding & cc_fits
    jobs.append((saving & (minerals >= 400) & mining.any(), F.Build_CommandCenter_screen.id,
                 builder(natural), natural, NO_TARGET))
    # 6. Workers.
    town = mine & complete & town_type
    idle_town = town & (units.queue[:, 0] == 0)
    workers = jnp.sum(mine & (types == UnitType.SCV)) + jnp.sum(
        jnp.where(town[:, None], units.queue == UnitType.SCV, False))
    jobs.append((idle_town.any() & (workers < lvl.workers) & (minerals >= 50)
                 & (free_supply >= 1), F.Train_SCV_quick.id, idle_town, home, NO_TARGET))
    # 7. Attack.
    wave = (state.game_loop >= lvl.first_attack) & (jnp.sum(army) >= lvl.wave)
    joining = jnp.where(wave, army & ~attacking, army & idle)
    jobs.append(((wave | attacking.any()) & joining.any(), F.Attack_screen.id, joining,
                 target, NO_TARGET))
    # 8. Tech.
    barracks = mine & (types == UnitType.BARRACKS)
    kind, addon_done = production.addon_kinds(units)
    bare = barracks & complete & (kind == 0) & (units.queue[:, 0] == 0)
    labs = jnp.sum(barracks & (kind == production.AddOn.TECH_LAB))
    jobs.append((lvl.tech & ~saving & (labs == 0) & bare.any() & (minerals >= 50)
                 & (vespene >= 25),
                 F.Build_TechLab_quick.id, one(jnp.argmax(bare)), home, NO_TARGET))
    lab = mine & complete & (types == UnitType.BARRACKS_TECH_LAB) & (units.queue[:, 0] == 0)
    stimming = production.pending(units, state.researched)[research.Research.STIMPACK]
    jobs.append((lvl.tech & ~saving & lab.any() & ~stimming & (minerals >= 100)
                 & (vespene >= 100),
                 F.Research_Stimpack_quick.id, lab, home, NO_TARGET))
    # 9. Army.
    ready = (barracks & complete & (units.queue[:, 0] == 0) & ((kind == 0) | addon_done)
             & ~saving)
    marauder = ready & (kind == production.AddOn.TECH_LAB)
    jobs.append((marauder.any() & (minerals >= 100) & (vespene >= 25) & (free_supply >= 2),
                 F.Train_Marauder_quick.id, one(jnp.argmax(marauder)), home, NO_TARGET))
    jobs.append((ready.any() & (minerals >= 50) & (free_supply >= 1), F.Train_Marine_quick.id,
                 one(jnp.argmax(ready)), home, NO_TARGET))
    # 10. Barracks.
    has_depot = production.has_structure(units, UnitType.SUPPLY_DEPOT)
    rax_fits, rax_site = _site(state, buildable, UnitType.BARRACKS, home, away, addon=True)
    rax = kind_count(UnitType.BARRACKS)
    more = (rax < lvl.barracks) | ((lvl.bank > 0) & (minerals >= lvl.bank)
                                   & (rax < MAX_BARRACKS))
    jobs.append((has_depot & more & ~saving & (minerals >= 150) & rax_fits & mining.any(),
                 F.Build_Barracks_screen.id, builder(rax_site), rax_site, NO_TARGET))
    # 11. Gas.
    geysers = units.alive & (types == UnitType.VESPENE_GEYSER)
    geyser = _nearest(geysers, units.pos, home)
    near_geyser = geysers.any() & (squared_length(units.pos[geyser] - home) < 15.0 ** 2)
    jobs.append((barracks.any() & ~saving & (kind_count(UnitType.REFINERY) < lvl.refineries)
                 & near_geyser & (minerals >= 75) & mining.any(), F.Build_Refinery_screen.id,
                 builder(units.pos[geyser]), units.pos[geyser], geyser))
    refineries = mine & complete & (types == UnitType.REFINERY)
    gas_of = jnp.where(units.orders[:, 0] == Order.GATHER, gathered, units.home)
    on_gas = jnp.sum(scv[:, None] & (gas_of[:, None] == jnp.arange(n)), axis=0)
    short = refineries & (on_gas < GAS_WORKERS)
    refinery = _nearest(short, units.pos, home)
    jobs.append((short.any() & mining.any(), F.Harvest_Gather_screen.id,
                 builder(units.pos[refinery]), units.pos[refinery], refinery))
    # 12. Scouting.
    scout_now = (lvl.scout_at > 0) & (state.game_loop >= lvl.scout_at) & (
        state.game_loop < lvl.scout_at + 8 * lvl.period)
    jobs.append((scout_now & mining.any(), F.Move_screen.id, builder(enemy_home), enemy_home,
                 NO_TARGET))

    applies = jnp.stack([j[0] for j in jobs])
    acting = (state.episode_step % lvl.period) == 0
    pick = jnp.where(acting & applies.any(), jnp.argmax(applies), len(jobs))
    column = lambda i, default: jnp.stack(  # noqa: E731
        [jnp.asarray(j[i]) for j in jobs] + [jnp.asarray(default)])[pick]
    return RawCommand(
        function=column(1, F.no_op.id).astype(jnp.int32),
        units=column(2, jnp.zeros(n, bool)),
        point=column(3, home).astype(jnp.float32),
        target=column(4, NO_TARGET).astype(jnp.int32),
        queued=jnp.int32(0))
