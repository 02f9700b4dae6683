"""Production: supply, training queues, and structures that SCVs place and construct.

The Terran rules of the economy mini-games (reference/pysc2_facts.md §7) and of the full
game, with the costs, times, producers and requirements of the Terran data table
(`terran_data`), vectorised over the N unit slots:

- **Supply.** Complete Command Centers provide 15 food and complete Supply Depots 8 (at
  most 200). Food used counts the living units and the units in training.
- **Training.** `Train_*` at a structure that trains the unit (`MAKES`: the Command
  Center SCVs, the Barracks Marines and Reapers, the Factory Hellions, the Starport
  Medivacs and Vikings) pays the minerals and vespene when queued (`enqueue`); a queue
  holds 5. The first unit of a queue trains once the
  supply allows it (else it waits), for its build time, and appears beside the producer,
  on the side of the rally point; it walks to the rally, and a new SCV rallied to a
  resource gathers from it. Cancelling a queued unit refunds its cost.
- **Upgrades** (`morphs`): a Command Center trains its Orbital Command as a unit, alone
  in its queue, and becomes it when done.
- **Research** (`research`): a Barracks Tech Lab or an Engineering Bay queues its
  researches as items (`research.item`), each once per player, and sets the player's
  upgrade when one is done.
- **Add-ons.** `Build_TechLab` and `Build_Reactor` at an idle Barracks, Factory or
  Starport without one place its add-on (2 x 2) unfinished at `ADDON_OFFSET` from it,
  paid for then; it is built in its build time while the producer, busy, trains
  nothing. A Tech Lab lets its producer train the Marauder and the Siege Tank
  (`NEEDS_ADDON`); with a Reactor it trains two units at once from a queue of 8.
- **Construction.** An SCV told to build walks to the site; on arrival the site is checked
  again (placement, cost, tech), the structure appears with 10% of its health and the
  cost is paid, and the SCV constructs it, standing at its edge, for the build time
  while the health grows to full. A structure whose SCV leaves waits unfinished until an
  SCV resumes it. Cancelling an unfinished structure refunds 75% of its cost.
- **Placement.** The footprint (`UnitData.footprint`, snapped to the cell grid) must lie on
  buildable cells and must not overlap another structure or resource footprint (own units
  standing there are pushed aside); a Command Center also keeps 3 cells away from
  resources; a Refinery goes on a free Vespene Geyser, which it replaces.
- **Tech.** A type needs a complete structure (`REQUIRED`: the Barracks a Supply Depot,
  the Factory and the Bunker a Barracks, the Starport a Factory, the Engineering Bay a
  Command Center), or one that counts as it (`COUNTS_AS`: an Orbital Command is a
  Command Center).

The map's creation of units goes through free (dead) slots; with none free, a trained
unit waits in the queue and a structure is not placed (docs/fidelity.md).
"""

from __future__ import annotations

import enum
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine import terran_data
from sc2jax.environment.engine.rules import commands, morphs, research
from sc2jax.environment.engine.rules.dynamics import pop_order
from sc2jax.environment.engine.rules.geometry import squared_length
from sc2jax.environment.engine.rules.state import (
    BUILD_QUEUE,
    NO_TARGET,
    Order,
    Owner,
    Units,
    first_slots,
    open_slots,
    place_where,
    targeted_by,
)
from sc2jax.environment.engine.rules.units import UNIT_DATA, Attribute, UnitType, terran_types
from sc2jax.environment.engine.xla.lazy import lazy_where
from sc2jax.environment.interface.protocol_enums import ActionResult

MAX_SUPPLY = 200
START_HEALTH = 0.1
"""The share of its health a structure starts construction with."""
CANCEL_REFUND = 0.75
"""The share of its cost an unfinished structure refunds when cancelled."""
ENERGY_PER_LOOP = 0.5625 / 16
"""Energy regeneration: 0.5625 per game second (0.7875 per second at Faster speed)."""
RESOURCE_CLEARANCE = 3
"""Cells a Command Center's footprint keeps from mineral fields and geysers: the game's
no-build zone, its corners cut (`near_resources`)."""

QUEUE = 5
"""A producer's training queue; `BUILD_QUEUE` (8) with a complete Reactor."""
ADDON_OFFSET = (2.5, -0.5)
"""An add-on's centre from its producer's: a 2 x 2 footprint flush with the 3 x 3
producer's right side, its lower edges level."""


class AddOn(enum.IntEnum):
    """The kinds of add-on; each producer's own type of each (`ADDON_OF`)."""

    NONE = 0
    TECH_LAB = 1
    REACTOR = 2


# What the Terran data table says each type makes, needs and counts as; types the table
# does not hold make nothing. The MULE is called down for energy (`calldown`), not made.
_NOT_YET = (UnitType.MULE,)


def _terran_tables():
    types = terran_types()
    t_count = len(UnitType)
    makes = np.zeros((t_count, t_count), bool)
    required = np.zeros(t_count, np.int32)
    counts_as = np.arange(t_count, dtype=np.int32)
    addon_kind = np.zeros(t_count, np.int32)
    addon_of = np.zeros((t_count, len(AddOn)), np.int32)
    needs_addon = np.zeros(t_count, np.int32)
    kinds = {"TechLab": AddOn.TECH_LAB, "Reactor": AddOn.REACTOR}
    for name, t in types.items():
        row = terran_data.unit(name)
        kind = next((k for suffix, k in kinds.items() if name.endswith(suffix)), 0)
        if kind and row["producers"]:
            addon_kind[t] = kind
            (producer,) = row["producers"]
            addon_of[types[producer], kind] = t
        elif t not in _NOT_YET:
            for producer in row["producers"]:
                makes[types[producer], t] = True
        if row["requires"]:
            required[t] = types[row["requires"]]
        if row["requires_addon"]:
            needs_addon[t] = kinds[row["requires_addon"]]
        if row["tech_alias"] in types:
            counts_as[t] = types[row["tech_alias"]]
    return makes, required, counts_as, addon_kind, addon_of, needs_addon


MAKES, REQUIRED, COUNTS_AS, ADDON_KIND, ADDON_OF, NEEDS_ADDON = _terran_tables()
"""MAKES: bool[T, T], [producer, made]: a structure trains the unit, or an SCV builds
the structure. REQUIRED: int32[T] the structure a type needs (0: none). COUNTS_AS:
int32[T] the type each counts as for requirements (a lowered Supply Depot or a flying
Barracks as itself landed, an Orbital Command as a Command Center). ADDON_KIND: int32[T]
the `AddOn` each add-on type is (0 for the others). ADDON_OF: int32[T, 3], [producer,
kind]: the add-on type a producer builds (0: none). NEEDS_ADDON: int32[T] the `AddOn`
the producer of a unit must have (the Marauder's and Siege Tank's Tech Lab)."""
TRAINERS = MAKES.any(axis=1) & ((UNIT_DATA.attributes & Attribute.STRUCTURE) > 0)
"""bool[T]: the structures that train units (into a queue, with a rally)."""
BUILDS = tuple(UnitType(t) for t in np.flatnonzero(MAKES[UnitType.SCV]))
"""The structures an SCV builds."""


def _item_tables():
    r = len(research.Research)
    unit_cost = np.stack([UNIT_DATA.mineral_cost, UNIT_DATA.vespene_cost], axis=-1)
    queues = np.zeros((len(UnitType), research.NUM_ITEMS), bool)
    queues[:, :research.FIRST] = MAKES & TRAINERS[:, None]
    queues |= morphs.UPGRADE
    queues[research.AT, research.FIRST + np.arange(r)] = True
    pad = lambda table: np.pad(table, (0, r))  # noqa: E731
    return (np.concatenate([unit_cost, research.COST]).astype(np.int32),
            np.concatenate([UNIT_DATA.build_time, research.TIME]).astype(np.float32),
            pad(UNIT_DATA.food).astype(np.float32), queues, pad(REQUIRED), pad(NEEDS_ADDON))


ITEM_COST, ITEM_TIME, ITEM_FOOD, QUEUES, ITEM_REQUIRED, ITEM_NEEDS_ADDON = _item_tables()
"""Per queue item (`research.NUM_ITEMS`: the unit types, then the researches):
ITEM_COST int32[I, 2] minerals and vespene, ITEM_TIME float32[I] loops, ITEM_FOOD
float32[I] supply, ITEM_REQUIRED and ITEM_NEEDS_ADDON int32[I] (`REQUIRED`,
`NEEDS_ADDON`; none for research). QUEUES: bool[T, I], [holder, item]: a structure
queues the item (trains the unit, trains the upgrade, or researches)."""


def _column(name, types):
    return jnp.asarray(getattr(UNIT_DATA, name))[types]


def _own(units: Units):
    return units.alive & (units.owner == Owner.SELF)


def food_cap(units: Units):
    """int32: the supply the player's complete structures provide (at most 200)."""
    supply = jnp.sum(jnp.where(_own(units) & units.complete, _column("supply", units.type), 0))
    return jnp.minimum(supply, MAX_SUPPLY).astype(jnp.int32)


def food_used(units: Units):
    """float32: the food of the player's living units and of the units in training."""
    own = _own(units)
    living = jnp.sum(jnp.where(own, _column("food", units.type), 0.0))
    training = jnp.sum(jnp.where(own[:, None] & (units.queue_work > 0),
                                 jnp.asarray(ITEM_FOOD)[units.queue], 0.0))
    return living + training


def has_structure(units: Units, unit_type):
    """bool: the player has a complete structure that counts as `unit_type` (int32)."""
    counts_as = jnp.asarray(COUNTS_AS)[units.type]
    return jnp.any(_own(units) & units.complete & (counts_as == unit_type))


def tech_ok(units: Units, unit_type):
    """bool: the tech requirement of making `unit_type` (int32, a queue item) is met."""
    needed = jnp.asarray(ITEM_REQUIRED)[unit_type]
    return (needed == 0) | has_structure(units, needed)


MIN_BUILD_LOOPS = int(UNIT_DATA.build_time[UNIT_DATA.build_time > 0].min())
"""The shortest build time, in game loops (an SCV's)."""


def creators(units: Units):
    """int32[N]: the most units each slot can create within `MIN_BUILD_LOOPS` game loops
    with no new action: producers one per build time, two with a Reactor, and SCVs with
    a Build order one (they place one structure, then construct it for its build
    time)."""
    builds = jnp.any(units.orders == Order.BUILD, axis=1)
    made = jnp.where(trains(units), _lanes(units), builds.astype(jnp.int32))
    return jnp.where(_own(units), made, 0)


def trains(units: Units):
    """bool[N]: the slots holding structures that train units."""
    return jnp.asarray(TRAINERS)[units.type]


def addon_kinds(units: Units):
    """Each slot's add-on: (int32[N] its `AddOn` kind, 0 for none; bool[N] it is
    complete). An add-on is a producer's while its slot holds a living add-on at
    `ADDON_OFFSET` from it (a slot freed and filled again is not)."""
    n = units.num_slots
    slot = jnp.clip(units.addon, 0, n - 1)
    kind = jnp.asarray(ADDON_KIND)[units.type[slot]]
    beside = jnp.all(jnp.abs(units.pos[slot] - units.pos - jnp.asarray(ADDON_OFFSET)) < 1e-3,
                     axis=-1)
    attached = (units.addon >= 0) & units.alive & units.alive[slot] & (kind > 0) & beside
    return jnp.where(attached, kind, 0), attached & units.complete[slot]


def _lanes(units: Units):
    """int32[N]: the units each producer trains at once: 2 with a complete Reactor."""
    kind, complete = addon_kinds(units)
    return jnp.where(complete & (kind == AddOn.REACTOR), 2, 1)


def queue_room(units: Units):
    """int32[N]: each producer's queue length: 5, `BUILD_QUEUE` (8) with a complete
    Reactor."""
    return jnp.where(_lanes(units) == 2, BUILD_QUEUE, QUEUE)


def upgrading(units: Units):
    """bool[N]: the structures whose queue holds an upgrade (`morphs.UPGRADE`)."""
    return jnp.asarray(morphs.UPGRADE)[units.type[:, None], units.queue].any(axis=1)


def queue_cost(holder, item):
    """int32[..., 2]: what queueing `item` (int32[...], a queue item) at a `holder`
    (int32[...]) costs: the unit's or research's cost, or for an upgrade the new form's
    less the old one's (the table's costs of morphed forms include their first form's)."""
    upgrade = jnp.asarray(morphs.UPGRADE)[holder, item]
    return jnp.asarray(ITEM_COST)[item] - jnp.where(upgrade[..., None], cost(holder), 0)


def pending(units: Units, researched):
    """bool[R]: the research done (bool[R] `researched`) or in one of the player's
    queues; neither can be queued again."""
    return jnp.asarray(researched) | research.queued(units.queue, _own(units)[:, None])


def equipped(units: Units, unit_type):
    """bool[N]: the slots whose add-on lets them make `unit_type` (int32, a queue item): a
    complete one of the kind it `NEEDS_ADDON`, or any slot where it needs none."""
    needed = jnp.asarray(ITEM_NEEDS_ADDON)[unit_type]
    kind, complete = addon_kinds(units)
    return (needed == 0) | (complete & (kind == needed))


def cost(unit_type):
    """int32[..., 2]: the minerals and vespene making `unit_type` (int32[...]) costs."""
    return jnp.stack([_column("mineral_cost", unit_type),
                      _column("vespene_cost", unit_type)], axis=-1).astype(jnp.int32)


def snap(unit_type, point):
    """float32[2]: the site of a structure placed at `point`: the footprint's centre on
    the cell grid (x.5 for odd widths, whole numbers for even ones)."""
    size = _column("footprint", unit_type).astype(jnp.float32)
    half = size / 2
    return jnp.floor(point - half + 0.5) + half


def _rect_overlap(centre, size, others, other_size):
    """bool[M]: the rectangle (centre float32[2], size float32[2]) overlaps each other
    rectangle (float32[M, 2] centres, float32[M, 2] sizes)."""
    gap = jnp.abs(others - centre) - (size + other_size) / 2
    return jnp.all(gap < -1e-4, axis=-1)


def near_resources(site, size, others, other_size):
    """bool[M]: a Command Center's footprint (centre float32[2], size float32[2]) is
    within `RESOURCE_CLEARANCE` cells of each resource's (float32[M, 2] centres and
    sizes) both across and along, unless it is at least `RESOURCE_CLEARANCE` - 1 cells
    off both ways: the zone's corners are cut. Every start location of the ladder
    layouts has a mineral field 2 cells off diagonally (`melee.base_sites` finds each
    start location by this rule)."""
    gap = jnp.abs(others - site) - (size + other_size) / 2
    close = jnp.all(gap < RESOURCE_CLEARANCE - 1e-4, axis=-1)
    return close & ~jnp.all(gap > RESOURCE_CLEARANCE - 1 - 1e-4, axis=-1)


def placement(units: Units, buildable, unit_type, site, target=NO_TARGET):
    """Whether a structure fits at a site.

    Args:
      units: the units.
      buildable: bool[H, W] the map's buildable cells, row 0 at the top.
      unit_type: int32 the structure.
      site: float32[2] its snapped centre.
      target: int32 the geyser slot a Refinery is built on.

    Returns:
      int32 `ActionResult`: 0 if it fits, else why not.
    """
    n = units.num_slots
    h, w = buildable.shape
    size = _column("footprint", unit_type).astype(jnp.float32)
    # Every cell of the footprint (at most 5 x 5) must be buildable.
    offsets = jnp.arange(5, dtype=jnp.float32)
    xs = site[0] - size[0] / 2 + 0.5 + offsets
    ys = site[1] - size[1] / 2 + 0.5 + offsets
    used = (offsets[:, None] < size[1]) & (offsets[None, :] < size[0])
    cols = jnp.floor(xs).astype(jnp.int32)
    rows = h - 1 - jnp.floor(ys).astype(jnp.int32)
    inside = (((rows >= 0) & (rows < h))[:, None] & ((cols >= 0) & (cols < w))[None, :])
    cells = jnp.asarray(buildable)[jnp.clip(rows, 0, h - 1)[:, None],
                                   jnp.clip(cols, 0, w - 1)[None, :]]
    on_ground = jnp.all(~used | (inside & cells))

    other_size = _column("footprint", units.type).astype(jnp.float32)
    blocks = units.alive & (other_size[:, 0] > 0)
    overlap = jnp.any(blocks & _rect_overlap(site, size, units.pos, other_size))
    resource = units.alive & (_column("contents", units.type) > 0)
    too_close = (unit_type == UnitType.COMMAND_CENTER) & jnp.any(
        resource & near_resources(site, size, units.pos, other_size))

    geyser = jnp.clip(target, 0, n - 1)
    free_geyser = ((target >= 0) & units.alive[geyser]
                   & (units.type[geyser] == UnitType.VESPENE_GEYSER))
    refinery = unit_type == UnitType.REFINERY
    ground_result = jnp.where(~on_ground, int(ActionResult.CantBuildLocationInvalid),
                              jnp.where(overlap, int(ActionResult.CantFindPlacementLocation),
                                        jnp.where(too_close,
                                                  int(ActionResult.CantBuildTooCloseToResources),
                                                  0)))
    return jnp.where(refinery, jnp.where(free_geyser, 0, int(ActionResult.CantTargetThatUnit)),
                     ground_result).astype(jnp.int32)


def affordable(bank, price):
    """int32 `ActionResult`: 0, NotEnoughMinerals or NotEnoughVespene, for paying
    `price` (int32[2], as `cost`) from `bank` (int32[2] minerals and vespene)."""
    return jnp.where(bank[0] < price[0], int(ActionResult.NotEnoughMinerals),
                     jnp.where(bank[1] < price[1], int(ActionResult.NotEnoughVespene),
                               0)).astype(jnp.int32)


def free_slots(units: Units, count: int):
    """int32[count]: the first `count` open slots (`open_slots`), ascending; N where
    there are fewer."""
    return first_slots(open_slots(units), count)


class Economy(NamedTuple):
    """The player's side of a loop of production.

    Attributes:
      units: the units.
      bank: int32[2] the player's minerals and vespene.
      next_tag: int32 the next unit tag.
      spent: int32[2] minerals and vespene spent this loop on structures.
      created: bool[N] slots where a unit was trained or a structure placed this loop.
      researched: bool[R] the research finished this loop.
    """

    units: Units
    bank: jax.Array
    next_tag: jax.Array
    spent: jax.Array
    created: jax.Array
    researched: jax.Array


def enqueue(units: Units, bank, unit_type, researched):
    """`Train_*`, upgrades (`morphs.UPGRADES`) and `Research_*`: queues one `unit_type`
    (a queue item) at the selected structure that queues it with the shortest queue,
    paying its cost. A unit that needs an add-on (`NEEDS_ADDON`) is queued only at a
    producer with it complete; an upgrade only in an empty queue, and nothing behind it
    (CantQueueThatOrder); a research only while not `pending` (Error).

    Args:
      units: the units.
      bank: int32[2] the player's minerals and vespene.
      unit_type: int32 the queue item.
      researched: bool[R] the player's research done.

    Returns:
      (units, bank, result int32 `ActionResult`).
    """
    q = jnp.arange(BUILD_QUEUE)
    length = jnp.sum(units.queue != 0, axis=1)
    upgrade = jnp.asarray(morphs.UPGRADE)[units.type, unit_type]
    maker = (units.selected & _own(units) & units.complete
             & jnp.asarray(QUEUES)[units.type, unit_type])
    last = len(research.Research) - 1
    taken = (unit_type >= research.FIRST) & pending(units, researched)[
        jnp.clip(unit_type - research.FIRST, 0, last)]
    producer = maker & equipped(units, unit_type)
    free = jnp.where(upgrade, length == 0, (length < queue_room(units)) & ~upgrading(units))
    room = producer & free
    slot = jnp.argmin(jnp.where(room, length, BUILD_QUEUE + 1))
    price = queue_cost(units.type[slot], unit_type)
    food = jnp.asarray(ITEM_FOOD)[unit_type]
    payable = affordable(bank, price)
    full = jnp.where((producer & (upgrade | upgrading(units))).any(),
                     int(ActionResult.CantQueueThatOrder), int(ActionResult.QueueIsFull))
    result = jnp.where(
        ~maker.any() | taken, int(ActionResult.Error),
        jnp.where(~producer.any() | ~tech_ok(units, unit_type),
                  int(ActionResult.TechRequirementsNotMet),
                  jnp.where(~room.any(), full,
                            jnp.where(payable != 0, payable,
                                      jnp.where(food_used(units) + food > food_cap(units),
                                                int(ActionResult.NotEnoughFood), 0))))
    ).astype(jnp.int32)
    ok = result == 0
    at = ok & (jnp.arange(units.num_slots)[:, None] == slot) & (q[None, :] == length[slot])
    units = units.replace(queue=jnp.where(at, unit_type, units.queue))
    return units, bank - jnp.where(ok, price, 0), result


def order_build(units: Units, bank, buildable, unit_type, point, picked, queued):
    """`Build_*`: the selected SCV nearest the site is ordered to build `unit_type` there.

    The site is `point` snapped to the grid, or for a Refinery the geyser `picked` (the
    slot under the click). Cost, placement and tech are checked now, and again when the
    SCV arrives.

    Args:
      units: the units.
      bank: int32[2] the player's minerals and vespene.
      buildable: bool[H, W] the map's buildable cells.
      unit_type: int32 the structure.
      point: float32[2] the clicked world point.
      picked: int32 the slot drawn at the click, or -1.
      queued: int32 0 (now) or 1 (queued).

    Returns:
      (units, result int32 `ActionResult`).
    """
    n = units.num_slots
    refinery = unit_type == UnitType.REFINERY
    site = jnp.where(refinery, units.pos[jnp.clip(picked, 0, n - 1)], snap(unit_type, point))
    target = jnp.where(refinery, picked, NO_TARGET)
    builders = units.selected & _own(units) & (units.type == UnitType.SCV)
    distance = squared_length(units.pos - site)
    builder = jnp.argmin(jnp.where(builders, distance, jnp.inf))
    placed = placement(units, buildable, unit_type, site, target)
    payable = affordable(bank, cost(unit_type))
    result = jnp.where(~builders.any(), int(ActionResult.Error), jnp.where(
        ~tech_ok(units, unit_type), int(ActionResult.TechRequirementsNotMet),
        jnp.where(payable != 0, payable, placed))).astype(jnp.int32)
    one = units.replace(selected=jnp.arange(n) == builder)
    ordered, _ = commands.issue(one, Order.BUILD, queued, site, target, unit_type)
    ordered = ordered.replace(selected=units.selected)
    return jax.tree_util.tree_map(lambda a, b: jnp.where(result == 0, a, b), ordered,
                                  units), result


def build_addon(units: Units, bank, next_tag, buildable, kind):
    """`Build_TechLab_quick`, `Build_Reactor_quick`: each selected idle producer without
    an add-on starts its own type of add-on of `kind` (int32 `AddOn`) at
    `ADDON_OFFSET` from it, where the footprint fits, paying for each in slot order
    while the bank lasts. The add-on starts unfinished, at `START_HEALTH`.

    Args:
      units: the units.
      bank: int32[2] the player's minerals and vespene.
      next_tag: int32 the next unit tag.
      buildable: bool[H, W] the map's buildable cells.
      kind: int32 the `AddOn`.

    Returns:
      (units, bank, next_tag, result int32 `ActionResult`: 0 if any started, else why
      the first candidate did not).
    """
    addon_type = jnp.asarray(ADDON_OF)[units.type, kind]
    candidates = (units.selected & _own(units) & units.complete & (addon_type > 0)
                  & (addon_kinds(units)[0] == 0))
    idle = candidates & jnp.all(units.queue == 0, axis=1)
    sites = units.pos + jnp.asarray(ADDON_OFFSET, jnp.float32)
    fits = jax.vmap(lambda t, site: placement(units, buildable, t, site))(addon_type, sites)
    price = cost(addon_type)  # [N, 2]
    placeable = idle & (fits == 0)
    paid_so_far = jnp.cumsum(jnp.where(placeable[:, None], price, 0), axis=0)
    dead = open_slots(units)
    rank = jnp.cumsum(placeable, dtype=jnp.int32) - 1
    starts = (placeable & jnp.all(paid_so_far <= bank, axis=-1)
              & (rank < jnp.sum(dead, dtype=jnp.int32)))
    # The k-th add-on takes the k-th open slot ([producer, slot] pairs, as `_spawn`).
    dead_rank = jnp.cumsum(dead, dtype=jnp.int32) - 1
    pairs = starts[:, None] & dead[None, :] & (rank[:, None] == dead_rank[None, :])
    filled = pairs.any(axis=0)
    producer = jnp.argmax(pairs, axis=0)
    new = place_where(units, filled, addon_type[producer], Owner.SELF, sites[producer],
                      next_tag + rank[producer])
    new = new.replace(
        progress=jnp.where(filled, 0.0, new.progress),
        health=jnp.where(filled, new.health * START_HEALTH, new.health),
        addon=jnp.where(starts, jnp.argmax(pairs, axis=1), new.addon))
    first = jnp.argmax(candidates)
    why = jnp.where(
        ~candidates.any(), int(ActionResult.Error),
        jnp.where(~idle[first], int(ActionResult.CantQueueThatOrder),
                  jnp.where(fits[first] != 0, fits[first],
                            jnp.where(affordable(bank, price[first]) != 0,
                                      affordable(bank, price[first]),
                                      int(ActionResult.Error)))))
    result = jnp.where(starts.any(), 0, why).astype(jnp.int32)
    spent = jnp.sum(jnp.where(starts[:, None], price, 0), axis=0)
    return new, bank - spent, next_tag + jnp.sum(starts, dtype=jnp.int32), result


def set_rally(units: Units, point, picked):
    """`Rally_*` (and `Smart` for producers): the selected producers rally to `point`,
    or to the resource or unit `picked` (int32 slot, or -1).

    Returns:
      (units, ok bool).
    """
    producers = units.selected & _own(units) & trains(units)
    return units.replace(
        rally=jnp.where(producers[:, None], point, units.rally),
        rally_unit=jnp.where(producers, picked, units.rally_unit),
        rallied=units.rallied | producers), producers.any()


def _compact(values, keep):
    """[..., B] `values` with the items where bool[..., B] `keep` holds moved to the
    front in order, zeros after them."""
    b = values.shape[-1]
    at = jnp.cumsum(keep, axis=-1) - 1
    moved = keep[..., :, None] & (at[..., :, None] == jnp.arange(b))  # [..., from, to]
    return jnp.sum(jnp.where(moved, values[..., :, None], 0), axis=-2).astype(values.dtype)


def _remove_queued(units: Units, producer, index):
    """Removes item `index` (int32) from the queue of slot `producer` (int32), with its
    training work; returns (units, the removed type)."""
    keep = jnp.arange(BUILD_QUEUE) != index
    removed = units.queue[producer, index]
    return units.replace(
        queue=units.queue.at[producer].set(_compact(units.queue[producer], keep)),
        queue_work=units.queue_work.at[producer].set(
            _compact(units.queue_work[producer], keep))), removed


def cancel_queued(units: Units, bank, index=None):
    """`Cancel_Last` (index None: the last unit of the selected producer with the longest
    queue) or the `build_queue` panel (the unit at `index` of the single selected
    producer's queue); refunds its cost to `bank` (int32[2] minerals and vespene).

    Returns:
      (units, bank, result int32 `ActionResult`).
    """
    length = jnp.sum(units.queue != 0, axis=1)
    chosen = units.selected & _own(units) & (length > 0)
    producer = jnp.argmax(jnp.where(chosen, length, -1))
    item = length[producer] - 1 if index is None else index
    ok = chosen.any() & (item >= 0) & (item < length[producer])
    new, removed = _remove_queued(units, producer, jnp.clip(item, 0, BUILD_QUEUE - 1))
    units = jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), new, units)
    refund = jnp.where(ok, queue_cost(units.type[producer], removed), 0)
    return units, bank + refund, jnp.where(ok, 0, int(ActionResult.Error)).astype(jnp.int32)


def cancel_construction(units: Units, bank, next_tag):
    """`Cancel` on the selected unfinished structures: they are removed and refund 75%
    of their cost to `bank` (int32[2] minerals and vespene); a cancelled Refinery gives
    its geyser back.

    Returns:
      (units, bank, next_tag, result int32 `ActionResult`).
    """
    doomed = units.selected & _own(units) & ~units.complete
    refund = jnp.sum(jnp.where(doomed[:, None], jnp.floor(
        CANCEL_REFUND * cost(units.type)), 0), axis=0).astype(jnp.int32)
    refineries = doomed & (units.type == UnitType.REFINERY)
    units = units.replace(alive=units.alive & ~doomed, selected=units.selected & ~doomed)
    # The geysers come back in the Refineries' own slots (tagged as if every slot got
    # one).
    rows = jnp.arange(units.num_slots, dtype=jnp.int32)
    geysers = place_where(units, refineries, UnitType.VESPENE_GEYSER, Owner.NEUTRAL,
                          units.pos, next_tag + rows)
    tag = next_tag + units.num_slots
    contents = jnp.where(refineries, units.contents, geysers.contents)
    return (geysers.replace(contents=contents), bank + refund, tag,
            jnp.where(doomed.any(), 0, int(ActionResult.Error)).astype(jnp.int32))


def production_loop(units: Units, bank, next_tag, buildable) -> Economy:
    """One game loop of production, after the loop's movement: structures placed by
    arriving SCVs, construction, training and research, and energy.

    Args:
      units: the units.
      bank: int32[2] the player's minerals and vespene.
      next_tag: int32 the next unit tag.
      buildable: bool[H, W] the map's buildable cells.
    """
    units, bank, next_tag, spent, placed = _place_arrivals(units, bank, next_tag, buildable)
    units = _construct(units)
    units, next_tag, trained, finished = _train(units, next_tag)
    return Economy(_regenerate(units), bank, next_tag, spent, placed | trained, finished)


def _regenerate(units: Units) -> Units:
    """Complete units with energy gain `ENERGY_PER_LOOP`, up to their maximum."""
    most = _column("max_energy", units.type)
    gaining = units.complete & (most > 0)
    return units.replace(energy=jnp.where(
        gaining, jnp.minimum(units.energy + ENERGY_PER_LOOP, most), units.energy))


def _place_arrivals(units: Units, bank, next_tag, buildable):
    """The first (lowest-slot) SCV to reach its BUILD site places its structure, if the
    site, the cost, the tech and a free slot allow; otherwise its order fails. One
    placement per loop: a second builder re-checks its site a loop later.

    Returns:
      (units, bank, next_tag, spent int32[2], placed bool[N] the new structure's slot).
    """
    n = units.num_slots
    rows = jnp.arange(n)
    kind = units.order_type[:, 0]
    site = units.order_pos[:, 0]
    reach = _column("radius", kind) + _column("radius", units.type) + 0.1
    arrived = (_own(units) & (units.orders[:, 0] == Order.BUILD)
               & (jnp.sqrt(squared_length(units.pos - site)) <= reach))
    builder = jnp.argmax(arrived)
    kind_b, site_b, geyser = kind[builder], site[builder], units.order_unit[builder, 0]
    slot = free_slots(units, 1)[0]
    ok = (arrived.any() & (placement(units, buildable, kind_b, site_b, geyser) == 0)
          & (affordable(bank, cost(kind_b)) == 0) & tech_ok(units, kind_b) & (slot < n))
    paid = jnp.where(ok, cost(kind_b), 0)
    # The structure, unfinished; a Refinery replaces its geyser and takes its gas.
    safe_geyser = jnp.clip(geyser, 0, n - 1)
    new = place_where(units, ok & (rows == slot), kind_b, Owner.SELF, site_b, next_tag)
    is_refinery = kind_b == UnitType.REFINERY
    new = new.replace(
        progress=new.progress.at[slot].set(0.0, mode="drop"),
        health=new.health.at[slot].multiply(START_HEALTH, mode="drop"),
        contents=new.contents.at[slot].set(
            jnp.where(is_refinery, units.contents[safe_geyser], 0.0), mode="drop"),
        alive=new.alive & ~(ok & is_refinery & (rows == safe_geyser)))
    # The builder steps to the structure's edge and constructs it.
    away = units.pos[builder] - site_b
    away = jnp.where(jnp.sum(away * away) > 1e-8, away, jnp.array([0.0, -1.0]))
    edge = site_b + away / jnp.sqrt(jnp.sum(away * away)) * (
        _column("radius", kind_b) + _column("radius", units.type[builder]))
    is_builder = rows == builder
    new = new.replace(
        pos=jnp.where(is_builder[:, None], edge, new.pos),
        orders=new.orders.at[builder, 0].set(Order.CONSTRUCT),
        order_unit=new.order_unit.at[builder, 0].set(slot))
    units = jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), new, units)
    failed = arrived & is_builder & ~ok
    units = pop_order(units, failed)
    return units, bank - paid, next_tag + ok.astype(jnp.int32), paid, ok & (rows == slot)


def _construct(units: Units) -> Units:
    """Unfinished structures with an SCV constructing them at their edge, and unfinished
    add-ons of living producers, advance a loop and gain health; SCVs whose structure
    is finished (or gone) stop."""
    n = units.num_slots
    target = units.order_unit[:, 0]
    safe = jnp.clip(target, 0, n - 1)
    constructing = _own(units) & (units.orders[:, 0] == Order.CONSTRUCT)
    gap = (jnp.sqrt(squared_length(units.pos - units.pos[safe]))
           - _column("radius", units.type) - _column("radius", units.type[safe]))
    working = (constructing & (target >= 0) & (gap <= 0.2)
               & (jnp.asarray(ADDON_KIND)[units.type[safe]] == 0))
    building_addon = addon_kinds(units)[0] > 0
    worked_slot = jnp.where(working, safe, jnp.where(building_addon, units.addon, NO_TARGET))
    worked = jnp.any(targeted_by(worked_slot, n), axis=0)
    build_time = _column("build_time", units.type)
    advancing = worked & units.alive & (units.progress < build_time)
    gain = (1.0 - START_HEALTH) * _column("max_health", units.type) / jnp.maximum(build_time, 1)
    units = units.replace(
        progress=jnp.where(advancing, units.progress + 1.0, units.progress),
        health=jnp.where(advancing, jnp.minimum(units.health + gain,
                                                 _column("max_health", units.type)),
                         units.health))
    finished = constructing & ((target < 0) | ~units.alive[safe]
                               | (units.progress[safe] >= build_time[safe]))
    return pop_order(units, finished)


def _train(units: Units, next_tag):
    """Queue heads (the first unit, the first two with a Reactor) train while the
    supply allows and no add-on is being built; finished units appear beside their
    producer and follow its rally, and finished research leaves its queue.

    Returns:
      (units, next_tag, trained bool[N] the new units' slots, finished bool[R] the
      research finished).
    """
    n = units.num_slots
    kind, addon_done = addon_kinds(units)
    ready = _own(units) & units.complete & ((kind == 0) | addon_done)
    heads = jnp.arange(BUILD_QUEUE) < _lanes(units)[:, None]
    producing = ready[:, None] & heads & (units.queue != 0)  # [N, B]
    food = jnp.asarray(ITEM_FOOD)[units.queue]
    # Heads not yet started take the free supply in slot order.
    started = producing & (units.queue_work > 0)
    waiting = producing & ~started
    free = food_cap(units) - food_used(units)
    claimed = jnp.cumsum(jnp.where(waiting, food, 0.0).reshape(-1)).reshape(waiting.shape)
    active = started | (waiting & (claimed <= free))
    work = jnp.where(active, units.queue_work + 1.0, units.queue_work)
    done = active & (work >= jnp.asarray(ITEM_TIME)[units.queue])
    # A finished upgrade (alone in its queue) turns its structure into the new form.
    upgraded = done & jnp.asarray(morphs.UPGRADE)[units.type[:, None], units.queue]
    units = morphs.upgrade_done(units, upgraded[:, 0])
    units = units.replace(queue=jnp.where(upgraded, 0, units.queue))
    researching = done & (units.queue >= research.FIRST)
    finished = research.queued(units.queue, researching)
    work, done = jnp.where(upgraded, 0.0, work), done & ~upgraded & ~researching
    # Units finish rarely: the spawning is computed only in loops where one does.
    units, next_tag, trained = lazy_where(
        done.any() | researching.any(), lambda args: _spawn(*args),
        (units, next_tag, done, researching, work),
        (units.replace(queue_work=work), next_tag, jnp.zeros(n, bool)))
    return units, next_tag, trained, finished


def _spawn(units: Units, next_tag, done, researched, work):
    """`_train`'s finished units (bool[N, B] `done`, by producer and queue place: the
    first two at most) appear beside their producers, and its finished research (bool[N,
    B] `researched`) leaves the queues; `work` (float32[N, B]) is the queue work this
    loop.

    Returns:
      (units, next_tag, trained bool[N] the new units' slots).
    """
    n = units.num_slots
    # The finished units of the first two queue places, producer by producer ([2N]).
    finished = done[:, :2].reshape(-1)
    made = units.queue[:, :2].reshape(-1)
    maker = jnp.repeat(jnp.arange(n), 2)
    # Each finished unit takes the next free slot (the k-th the k-th open slot); without
    # one it waits. Matched over [unit, slot] pairs and written by selects, not scatters
    # (`place_where`).
    rank = jnp.cumsum(finished, dtype=jnp.int32) - 1
    dead = open_slots(units)
    dead_rank = jnp.cumsum(dead, dtype=jnp.int32) - 1
    spawns = finished & (rank < jnp.sum(dead, dtype=jnp.int32))
    pairs = spawns[:, None] & dead[None, :] & (rank[:, None] == dead_rank[None, :])
    filled = pairs.any(axis=0)
    source = jnp.argmax(pairs, axis=0)  # [N]: the finished unit of each filled slot
    producer = maker[source]
    unit_type = made[source]
    radius = _column("radius", units.type)[producer] + _column("radius", unit_type)
    to_rally = units.rally - units.pos
    length = jnp.sqrt(squared_length(to_rally))
    towards = jnp.where((units.rallied & (length > 1e-4))[:, None],
                        to_rally / jnp.maximum(length, 1e-4)[:, None], jnp.array([0.0, -1.0]))
    spawn_pos = units.pos[producer] + towards[producer] * radius[:, None]
    # Tags in production order.
    new = place_where(units, filled, unit_type, Owner.SELF, spawn_pos, next_tag + rank[source])
    # Rallies: a new SCV rallied to a resource gathers it, others move to the point.
    rally_unit = jnp.clip(units.rally_unit, 0, n - 1)
    to_resource = ((units.rally_unit >= 0) & units.alive[rally_unit]
                   & (units.contents[rally_unit] > 0))[producer] & (unit_type == UnitType.SCV)
    order = jnp.where(units.rallied[producer], jnp.where(to_resource, Order.GATHER, Order.MOVE),
                      Order.NONE)
    head_of_queue = filled[:, None] & (jnp.arange(new.orders.shape[1]) == 0)  # [N, Q]

    def first_order(old, value):  # old [N, Q, ...] with value [N, ...] first where filled
        where = head_of_queue.reshape(head_of_queue.shape + (1,) * (old.ndim - 2))
        return jnp.where(where, value[:, None], old)

    new = new.replace(
        orders=first_order(new.orders, order),
        order_pos=first_order(new.order_pos, units.rally[producer]),
        order_unit=first_order(new.order_unit,
                               jnp.where(to_resource, units.rally_unit[producer], NO_TARGET)),
        patrol_origin=jnp.where(filled[:, None], spawn_pos, new.patrol_origin))
    # The trained units and research leave their queues; finished units without a
    # slot wait a loop.
    left = jnp.pad(spawns.reshape(n, 2), ((0, 0), (0, BUILD_QUEUE - 2))) | researched
    work = jnp.where(done & ~left, work - 1.0, work)
    new = new.replace(queue=_compact(units.queue, ~left), queue_work=_compact(work, ~left))
    return new, next_tag + jnp.sum(spawns, dtype=jnp.int32), filled
