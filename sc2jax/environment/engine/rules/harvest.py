"""Workers harvesting minerals and gas: the gather, mine, return and deposit cycle.

The game's cycle (reference/pysc2_facts.md §7), run once per game loop by
`dynamics.game_loop` for maps with workers:

- a worker with a GATHER order walks to its mineral field (the order's target unit);
- touching it (edge to edge within `REACH`), and if no other worker is mining it, it
  mines for 2.786 game seconds (`MINING_LOOPS`), then takes 5 minerals from the field
  (fewer if fewer are left), pauses 0.5 game seconds (`LEAVE_LOOPS`) and RETURNs them to
  the nearest own complete town hall (a landed Command Center or Orbital Command);
- touching the Command Center deposits the cargo, and the worker goes back to GATHER
  from the same field;
- a worker that finds its field taken waits, or moves on to a nearby field with fewer
  workers (`_spread`);
- a worker told to gather while it carries minerals returns them first;
- a field mined out disappears, and the workers on it go idle;
- gas the same way from the player's complete Refinery: 4 per trip after 1.981 game
  seconds inside (`GAS_LOOPS`); a Refinery with no gas left stays, and its workers go
  idle;
- a MULE (`calldown`) mines minerals only, 25 a trip (`MULE_TRIP`) for 3.85 times an
  SCV's mining time (`MULE_MINING_LOOPS`), and mines beside an SCV: a field is taken
  for a MULE only by another MULE mining it.

Moving and mining workers pass through other units, as harvesting workers do in the
game; they keep their orders' targets in `Units.order_unit`, and the field a worker
returns to in `Units.home`.
"""

from __future__ import annotations

import jax.numpy as jnp

from sc2jax.environment.engine.rules.geometry import distances
from sc2jax.environment.engine.rules.state import (
    NO_TARGET,
    Order,
    Units,
    first_slots,
    leading_slots,
    targeted_by,
)
from sc2jax.environment.engine.rules.units import LOOPS_PER_SECOND, UNIT_DATA, UnitType
from sc2jax.environment.engine.xla.fusion import first_argmin
from sc2jax.environment.engine.xla.lazy import lazy_where

REACH = 0.1
"""Edge-to-edge distance at which a worker touches a field or a Command Center."""
MINING_LOOPS = 2.786 * LOOPS_PER_SECOND
"""Loops a worker mines a mineral field for (2.786 game seconds: 45 whole loops)."""
MINERALS_PER_TRIP = 5.0
LEAVE_LOOPS = 0.5 * LOOPS_PER_SECOND
"""Loops a worker pauses at a mineral field after mining, before it leaves."""
GAS_LOOPS = 1.981 * LOOPS_PER_SECOND
"""Loops a worker harvests inside a Refinery for (1.981 game seconds: 32 whole loops)."""
GAS_PER_TRIP = 4.0
MULE_MINING_LOOPS = 3.85 * MINING_LOOPS
"""Loops a MULE mines a mineral field for (Liquipedia: 3.85 times an SCV's)."""
MULE_TRIP = 25.0
SPREAD_RADIUS = 8.0
"""How far a worker whose mineral field is taken looks for another one (world units)."""


def harvesting(units: Units):
    """bool[N]: living units with a GATHER or RETURN order."""
    order = units.orders[:, 0]
    return units.alive & ((order == Order.GATHER) | (order == Order.RETURN))


def working(units: Units):
    """bool[N]: living workers walking to (or busy at) a unit: harvesting or
    constructing. They pass through other units."""
    return harvesting(units) | (units.alive & (units.orders[:, 0] == Order.CONSTRUCT))


DEPOT_SLOTS = 4
"""Command Centers `nearest_depot` measures to directly; an environment with more (the
player built them) measures to every slot."""


def _town_hall(types):
    """bool[...]: the types (int32[...]) workers return cargo to."""
    return jnp.asarray(UNIT_DATA.town_hall)[types]


def nearest_depot(units: Units, eps=1e-12):
    """int32[N]: each unit's nearest own complete town hall (by centre distance,
    `distances` with `eps`; the lowest slot on a tie), or -1.

    It measures to the first `DEPOT_SLOTS` Command Centers ([N, 4] distances), and to
    every slot ([N, N]) only in an environment that has more (`lazy_where`).
    """
    n = units.num_slots
    depot = units.complete & _town_hall(units.type)
    first = first_slots(depot, DEPOT_SLOTS)
    return lazy_where(depot.sum() > DEPOT_SLOTS,
                      lambda u: _nearest_of(u, jnp.arange(n), eps), units,
                      _nearest_of(units, first, eps))


def _nearest_of(units: Units, slots, eps):
    """int32[N]: `nearest_depot` among the Command Centers in `slots` (int32[M],
    ascending; N marks none)."""
    n = units.num_slots
    at = jnp.clip(slots, 0, n - 1)
    depot = (slots < n) & units.complete[at] & _town_hall(units.type[at])
    mine = depot[None, :] & (units.owner[:, None] == units.owner[at][None, :])
    dist = distances(units.pos, units.pos[at], eps)
    nearest = at[first_argmin(jnp.where(mine, dist, jnp.inf))].astype(jnp.int32)
    return jnp.where(mine.any(axis=1), nearest, NO_TARGET)


def approach(units: Units, radius, static_slots: int = 0):
    """Where working workers (`working`) walk this loop.

    Args:
      units: the units.
      radius: float32[N] the units' radii.
      static_slots: (static) S where the first S slots hold only resources, which walk
        nowhere (`MiniGame.resource_slots`): the pairs are then [N - S, N].

    Returns:
      (walking bool[N], target int32[N] the unit walked to, room float32[N] the
      distance left before touching it; 0 for a worker already touching it).
    """
    n = units.num_slots
    walking = working(units) & (units.work <= 0)
    target = jnp.clip(units.order_unit[:, 0], 0, n - 1)
    # Edge to edge, from the [N, N] pair array: XLA rounds a per-row distance differently
    # in the last bit, and this keeps the engine's trajectories as they were.
    rows = slice(static_slots, n)
    gap = distances(units.pos[rows], units.pos) - radius[rows, None] - radius[None, :]
    left = jnp.concatenate([jnp.zeros(static_slots), gap[jnp.arange(n - static_slots),
                                                         target[rows]]])
    room = jnp.where(left > REACH, left - REACH + 1e-3, 0.0)
    return walking, target, room


def resolve_returns(units: Units, depot) -> Units:
    """Gives RETURN orders without a target (`Harvest_Return`) the nearest Command
    Center (`depot`, int32[N] from `nearest_depot`), before the loop's movement."""
    first = units.orders[:, 0] == Order.RETURN
    unset = first & (units.order_unit[:, 0] < 0)
    return units.replace(order_unit=units.order_unit.at[:, 0].set(
        jnp.where(unset, depot, units.order_unit[:, 0])))


def _spread(units: Units, field, blocked, contents, field_slots, static_slots: int = 0):
    """int32[N]: where workers that find their mineral field taken go next.

    One such worker per field a loop moves on to the nearby field (within
    `SPREAD_RADIUS`) with the fewest gatherers, nearest first, if that has at least two
    fewer than its own; the others keep waiting. This spreads workers over a mineral line
    as the game's do.

    Args:
      units: the units.
      field: int32[N] each worker's field (valid where `blocked`).
      blocked: bool[N] gatherers touching a taken field.
      contents: float32[N] the resources left.
      field_slots: (static) None, or the number of leading slots that can hold mineral
        fields (`MiniGame.field_slots`); the others are not looked at.
      static_slots: (static) as in `approach`: the workers are in the slots from it on.
    """
    n = units.num_slots
    workers = slice(static_slots, n)
    rows = jnp.arange(n)[workers]
    # Counted over the field slots alone (`targeted_by`'s [N, F]): a blocked worker's
    # field is a mineral field, so `field` lies among them where `blocked` holds.
    fields = leading_slots(units.alive & (units.type == UnitType.MINERAL_FIELD)
                           & (contents > 0), field_slots)
    f = fields.shape[0]
    gathering = units.alive & (units.orders[:, 0] == Order.GATHER)
    aims = targeted_by(jnp.clip(units.order_unit[workers, 0], 0, n - 1), f)
    assigned = jnp.sum(aims & gathering[workers, None], axis=0, dtype=jnp.int32)
    field, blocked = field[workers], blocked[workers]
    dist = distances(units.pos[field], leading_slots(units.pos, field_slots))
    near = fields[None, :] & (dist <= SPREAD_RADIUS)
    cost = jnp.where(near, assigned[None, :] * 1000.0 + dist, jnp.inf)
    best = first_argmin(cost)
    first = jnp.min(jnp.where(targeted_by(field, f) & blocked[:, None], rows[:, None], n),
                    axis=0)
    own = jnp.clip(field, 0, f - 1)
    moves = blocked & (first[own] == rows) & (assigned[best] < assigned[own] - 1)
    return jnp.concatenate([jnp.zeros(static_slots, field.dtype),
                            jnp.where(moves, best, field)])


def _free(aims, mining, waiting, field, kind):
    """bool[N]: each worker's field is free for it among the workers of its `kind`
    (bool[N]): none of them mines it, and the worker is the lowest slot of them waiting
    there.

    Args:
      aims: bool[N - S, N], [worker, unit]: the worker's field is the unit, for the
        slots from S on (the first S hold only resources: `MiniGame.resource_slots`).
      mining: bool[N] the workers mining on after this loop.
      waiting: bool[N] the workers at their field, waiting to mine.
      field: int32[N] each worker's field.
      kind: bool[N] the workers of the kind.
    """
    n = aims.shape[1]
    workers = slice(n - aims.shape[0], n)
    rows = jnp.arange(n)
    occupied = jnp.any(aims & (mining & kind)[workers, None], axis=0)
    first = jnp.min(jnp.where(aims & (waiting & kind)[workers, None], rows[workers, None], n),
                    axis=0)
    return ~occupied[field] & (first[field] == rows)


def harvest(units: Units, touching, depot, field_slots=None, static_slots: int = 0) -> tuple[
        Units, jnp.ndarray, jnp.ndarray, jnp.ndarray]:
    """One loop of the harvest cycle, after the loop's movement.

    Args:
      units: the units after moving.
      touching: bool[N] the unit touches its order's target unit.
      depot: int32[N] each unit's nearest Command Center (`nearest_depot`).
      field_slots: (static) as in `_spread`.
      static_slots: (static) as in `approach`.

    Returns:
      (units, minerals, vespene, done): minerals and vespene are float32[N], what each
      unit deposited; done is bool[N], the workers whose order ended (its resource or
      Command Center is gone, or there was nothing to return), for the caller to
      advance their order queues.
    """
    n = units.num_slots
    order, target = units.orders[:, 0], units.order_unit[:, 0]
    safe = jnp.clip(target, 0, n - 1)
    refinery = units.type[safe] == UnitType.REFINERY
    mule = units.type == UnitType.MULE
    harvestable = jnp.where(refinery, units.complete[safe] & (units.owner[safe] == units.owner)
                            & ~mule, units.type[safe] == UnitType.MINERAL_FIELD)
    field_ok = (target >= 0) & units.alive[safe] & (units.contents[safe] > 0) & harvestable
    gather = units.alive & (order == Order.GATHER)
    returning = units.alive & (order == Order.RETURN)

    # Mining: the clock runs down; a finished worker takes its cargo. A worker leaving a
    # mineral field pauses first (its RETURN waits while `work` > 0).
    mining = gather & (units.work > 0)
    pausing = returning & (units.work > 0)
    work = jnp.where(mining | pausing, units.work - 1.0, units.work)
    finished = mining & (work <= 0)
    trip = jnp.where(refinery, GAS_PER_TRIP, jnp.where(mule, MULE_TRIP, MINERALS_PER_TRIP))
    take = jnp.where(finished, jnp.minimum(trip, units.contents[safe]), 0.0)
    # By target over [N, N] pairs (the workers' rows: from `static_slots` on), not
    # scatters (`targeted_by`); the sum is exact in any order, as resources come in
    # whole units.
    aims = targeted_by(safe[static_slots:], n)
    contents = units.contents - jnp.sum(jnp.where(aims, take[static_slots:, None], 0.0),
                                        axis=0)

    # Starting to mine: at the field, empty-handed, the field free of its kind of worker
    # (SCVs and MULEs mine side by side); the lowest slot first.
    waiting = gather & ~mining & touching & field_ok & (units.cargo == 0)
    busy = (aims, mining & ~finished, waiting, safe)
    # MULEs are rare: the two kinds are told apart only in loops where one lives.
    free = lazy_where(jnp.any(units.alive & mule),
                      lambda a: jnp.where(a[0], _free(*a[1:], a[0]), _free(*a[1:], ~a[0])),
                      (mule, *busy), _free(*busy, jnp.ones(n, bool)))
    start = waiting & free
    mine_loops = jnp.where(mule, MULE_MINING_LOOPS, MINING_LOOPS)
    work = jnp.where(start, jnp.where(refinery, GAS_LOOPS, mine_loops),
                     jnp.where(finished, jnp.where(refinery, 0.0, LEAVE_LOOPS), work))
    blocked = waiting & ~start & ~refinery
    target = jnp.where(blocked, _spread(units, safe, blocked, contents, field_slots,
                                        static_slots), target)

    # Depositing at the Command Center.
    deposit = returning & touching & (units.cargo > 0)
    delivered = jnp.where(deposit, units.cargo, 0.0)
    cargo = jnp.where(finished, take, jnp.where(deposit, 0.0, units.cargo))
    gas = jnp.where(finished, refinery, units.gas)
    minerals = jnp.where(units.gas, 0.0, delivered)
    vespene = jnp.where(units.gas, delivered, 0.0)
    home = jnp.where(finished | (gather & ~mining), target, units.home)

    # Next orders: carrying workers return (also when told to gather); those that
    # deposited gather again; workers whose field or depot is gone go idle.
    to_return = (finished | (gather & ~mining & (cargo > 0))) & (depot >= 0)
    home_ok = (home >= 0) & units.alive[jnp.clip(home, 0, n - 1)] & (
        contents[jnp.clip(home, 0, n - 1)] > 0)
    to_gather = deposit & home_ok
    lost = ((gather & ~field_ok & ~finished) | (returning & ~deposit & (units.cargo == 0))
            | (returning & (target < 0)) | (deposit & ~home_ok))
    new_order = jnp.where(to_return, Order.RETURN, jnp.where(to_gather, Order.GATHER, order))
    new_target = jnp.where(to_return, depot, jnp.where(to_gather, home, target))
    units = units.replace(
        orders=units.orders.at[:, 0].set(new_order),
        order_unit=units.order_unit.at[:, 0].set(new_target),
        cargo=cargo, gas=gas, work=work, contents=contents, home=home,
        # A mined-out field disappears.
        alive=units.alive & ~((units.type == UnitType.MINERAL_FIELD) & (contents <= 0)))
    return units, minerals, vespene, lost
