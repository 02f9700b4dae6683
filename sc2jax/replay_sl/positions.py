"""Where mobile units are between the tracker's reports: estimated from the players' orders.

The tracker records a unit's point when it is born or placed, and every 240 game loops
for the units damaged since the last report. In between, the only evidence of where a
unit went is its player's commands with a target point (`actions.Order`). An estimate
at game loop L starts from the unit's last reported point before L and follows the
orders given to it after that report, in turn:

- "last": the last reported point (orders ignored);
- "target": the target of the last order (the unit got there);
- "move": a straight walk towards each order's target at the unit type's speed
  (`movement`), from where the previous order left it.

`errors` measures each against the points the tracker reports, from what was known
strictly before each report.
"""

from __future__ import annotations

import bisect
import collections

import numpy as np

from sc2jax.replay_sl.actions import Order
from sc2jax.replay_sl.movement import speed, walk
from sc2jax.replay_sl.units import UnitTable, unit_index

METHODS = ("last", "target", "move")
SPEED = 3.15 / 22.4
"""World units per game loop: a Marine's 3.15 per second at Faster speed (22.4 game loops
per second), a typical ground unit's speed; `estimate`'s default."""


def orders_by_unit(orders: list[Order]) -> dict[int, list[tuple[int, float, float]]]:
    """Tag index -> its (game loop, x, y) orders, in order."""
    out: dict[int, list[tuple[int, float, float]]] = collections.defaultdict(list)
    for order in orders:
        for index in order.units:
            out[index].append((order.game_loop, order.x, order.y))
    return out


def estimate(method: str, start: tuple[int, float, float],
             orders: list[tuple[int, float, float]], game_loop: int,
             speed: float = SPEED) -> tuple[float, float]:
    """A unit's point at `game_loop`, from its last report `start` (loop, x, y) and its
    orders (loop, x, y), in order, by `method` (one of `METHODS`).

    Raises:
      ValueError: for an unknown method.
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; allowed: {list(METHODS)}")
    t0, x, y = start
    after = [o for o in orders if t0 <= o[0] < game_loop]
    if method == "last" or not after:
        return x, y
    if method == "target":
        return after[-1][1], after[-1][2]
    for i, (t, tx, ty) in enumerate(after):
        end = after[i + 1][0] if i + 1 < len(after) else game_loop
        x, y = walk((x, y), (tx, ty), speed, end - t)
    return x, y


def errors(table: UnitTable, orders: list[Order], owner_ids: tuple[int, ...] = (1, 2),
           min_gap: int = 1) -> dict[str, np.ndarray]:
    """Each method's error (world units) at every tracker position report of a unit of
    `owner_ids` that had an order since its previous report.

    The estimate uses only what was known before the report: the unit's previous report
    (or its birth) and the orders given before it. Reports of units without orders since
    then are left out: every method gives the previous point for them. "move" walks at
    the speed of the unit's type at its previous report.

    Returns:
      method -> float32 [R] errors, one per report.
    """
    by_unit = orders_by_unit(orders)
    known: dict[int, list[tuple[int, float, float]]] = collections.defaultdict(list)
    index_of_row = unit_index(table.tag)
    for row in range(len(table.tag)):
        known[row].append((int(table.born[row]), float(table.x[row]), float(table.y[row])))
    types: dict[int, tuple[list[int], list[int]]] = {}  # Row -> (loops, its types from then).
    for loop, row, unit_type in table.type_changes.tolist():
        loops, kinds = types.setdefault(row, ([int(table.born[row])], [int(table.unit_type[row])]))
        loops.append(loop)
        kinds.append(unit_type)
    out = {m: [] for m in METHODS}
    for loop, row, x, y in table.positions:
        loop, row = int(loop), int(row)
        history = known[row]
        previous = history[bisect.bisect_right([h[0] for h in history], loop - min_gap) - 1]
        unit_orders = [o for o in by_unit.get(int(index_of_row[row]), [])
                       if previous[0] <= o[0] < loop and o[0] >= table.born[row]]
        if table.owner[row] in owner_ids and unit_orders:
            loops, kinds = types.get(row, ([0], [int(table.unit_type[row])]))
            unit_speed = speed(kinds[max(bisect.bisect_right(loops, previous[0]) - 1, 0)])
            for m in METHODS:
                ex, ey = estimate(m, previous, unit_orders, loop, unit_speed)
                out[m].append(float(np.hypot(ex - x, ey - y)))
        history.append((loop, float(x), float(y)))
    return {m: np.asarray(v, np.float32) for m, v in out.items()}
