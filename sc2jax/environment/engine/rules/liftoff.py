"""Lifting off and landing: the Command Center, Orbital Command, Barracks, Factory and
Starport fly (their flying forms in the Terran data table, `terran_data`).

- `Lift_quick`: the player's selected complete structures with nothing in their queue
  (and no add-on being built) become their flying form at once, with no orders.
  Flying, they move (and pass over everything), train nothing, and still count for
  supply and requirements. An add-on stays where it stands, no longer its producer's.
- `Land_screen`: the selected flying structure nearest the site (the clicked point
  snapped to its landed footprint) flies there; on arrival it lands at once where the
  footprint fits (as a structure is placed: `production.placement`), else its order
  ends and it hovers. A structure landing beside an add-on of its kind (a Tech Lab at
  `production.ADDON_OFFSET`) takes it, as its own type: a Factory landing by a Barracks
  Tech Lab has a Factory Tech Lab.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine import terran_data
from sc2jax.environment.engine.rules import commands, production
from sc2jax.environment.engine.rules.dynamics import pop_order
from sc2jax.environment.engine.rules.geometry import squared_length
from sc2jax.environment.engine.rules.state import NO_TARGET, Order, Owner, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType, terran_types
from sc2jax.environment.interface.protocol_enums import ActionResult


def _tables():
    flying, landed = np.zeros(len(UnitType), np.int32), np.zeros(len(UnitType), np.int32)
    types = terran_types()
    for name, t in types.items():
        source = terran_data.unit(name)["morphs_from"]
        if source and name.endswith("Flying"):
            flying[types[source]], landed[t] = t, types[source]
    return flying, landed


FLYING_FORM, LANDED_FORM = _tables()
"""int32[T]: each structure's flying form (0: it cannot lift off), and each flying
form's landed one."""

ARRIVAL = 1e-3
"""How near its site a landing structure must come, world units."""


def lift(units: Units):
    """`Lift_quick`: the selected complete structures with an empty queue, building no
    add-on, lift off.

    Returns:
      (units, result int32 `ActionResult`: Error with no such structure selected,
      CantQueueThatOrder when all of them are busy).
    """
    flying = jnp.asarray(FLYING_FORM)[units.type]
    able = commands.commandable(units) & units.complete & (flying > 0)
    kind, addon_done = production.addon_kinds(units)
    idle = jnp.all(units.queue == 0, axis=1) & ((kind == 0) | addon_done)
    lifting = able & idle
    rows = lifting[:, None]
    units = units.replace(
        type=jnp.where(lifting, flying, units.type),
        progress=jnp.where(lifting, jnp.asarray(UNIT_DATA.build_time)[flying], units.progress),
        addon=jnp.where(lifting, NO_TARGET, units.addon),
        orders=jnp.where(rows, Order.NONE, units.orders),
        order_unit=jnp.where(rows, NO_TARGET, units.order_unit),
        order_type=jnp.where(rows, 0, units.order_type))
    result = jnp.where(lifting.any(), 0, jnp.where(able.any(),
                                                   int(ActionResult.CantQueueThatOrder),
                                                   int(ActionResult.Error)))
    return units, result.astype(jnp.int32)


def order_land(units: Units, buildable, point, queued):
    """`Land_screen`: the selected flying structure nearest the site is ordered to land
    there; the site is checked now, and again on arrival.

    Args:
      units: the units.
      buildable: bool[H, W] the map's buildable cells.
      point: float32[2] the clicked world point.
      queued: int32 0 (now) or 1 (queued).

    Returns:
      (units, result int32 `ActionResult`).
    """
    n = units.num_slots
    landed = jnp.asarray(LANDED_FORM)[units.type]
    flyers = commands.commandable(units) & (landed > 0)
    sites = production.snap(landed, point)  # [N, 2]: each one's own footprint
    lander = jnp.argmin(jnp.where(flyers, squared_length(sites - units.pos), jnp.inf))
    kind, site = landed[lander], sites[lander]
    fits = production.placement(units, buildable, kind, site)
    result = jnp.where(flyers.any(), fits, int(ActionResult.Error)).astype(jnp.int32)
    one = units.replace(selected=jnp.arange(n) == lander)
    ordered, _ = commands.issue(one, Order.LAND, queued, site, NO_TARGET, kind)
    ordered = ordered.replace(selected=units.selected)
    return jax.tree.map(lambda a, b: jnp.where(result == 0, a, b), ordered, units), result


def land_arrivals(units: Units, buildable) -> Units:
    """The first (lowest-slot) flying structure at its landing site lands if its
    footprint fits there, taking an add-on of its kind beside it; otherwise its order
    ends. One landing per game loop.

    Args:
      units: the units.
      buildable: bool[H, W] the map's buildable cells.
    """
    n = units.num_slots
    rows = jnp.arange(n)
    site = units.order_pos[:, 0]
    own = units.alive & (units.owner == Owner.SELF)
    arrived = (own & (units.orders[:, 0] == Order.LAND)
               & (squared_length(units.pos - site) <= ARRIVAL ** 2))
    lander = jnp.argmax(arrived)
    kind, at = units.order_type[lander, 0], site[lander]
    lands = arrived.any() & (production.placement(units, buildable, kind, at) == 0)
    # An add-on of a kind this structure has, standing where its own would.
    addon_kind = jnp.asarray(production.ADDON_KIND)[units.type]
    beside = jnp.all(jnp.abs(units.pos - at - jnp.asarray(production.ADDON_OFFSET)) < 1e-3,
                     axis=-1)
    own_type = jnp.asarray(production.ADDON_OF)[kind, addon_kind]
    candidates = own & (addon_kind > 0) & beside & (own_type > 0)
    addon = jnp.where(lands & candidates.any(), jnp.argmax(candidates), NO_TARGET)
    is_lander = lands & (rows == lander)
    units = units.replace(
        type=jnp.where(is_lander, kind, jnp.where(rows == addon, own_type, units.type)),
        progress=jnp.where(is_lander, jnp.asarray(UNIT_DATA.build_time)[kind],
                           units.progress),
        pos=jnp.where(is_lander[:, None], at, units.pos),
        addon=jnp.where(is_lander, addon, units.addon))
    return pop_order(units, arrived & (rows == lander))
