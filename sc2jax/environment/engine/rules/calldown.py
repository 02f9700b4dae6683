"""The Orbital Command's Calldown: MULE, and the timed life of what it calls down.

`Effect_CalldownMULE_screen` spends 50 of a selected Orbital Command's energy (the one
with the most) to call down a MULE (Liquipedia, Legacy of the Void 5.0):

- on a mineral field clicked, beside it on the caster's side, gathering from it at once;
- elsewhere, at the point clicked, idle.

A MULE lives 64 seconds at Faster speed (`LIFE_LOOPS`) and then dies; it costs no
supply. It harvests minerals only, 25 a trip, mining 3.85 times as long as an SCV, and
mines a field beside an SCV: only another MULE keeps it waiting (`harvest`).
"""

from __future__ import annotations

import jax.numpy as jnp

from sc2jax.environment.engine.rules import commands
from sc2jax.environment.engine.rules.geometry import squared_length
from sc2jax.environment.engine.rules.state import (
    NO_TARGET,
    Order,
    Owner,
    Units,
    first_slots,
    open_slots,
    place_where,
)
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from sc2jax.environment.interface.protocol_enums import ActionResult

ENERGY = 50.0
"""The energy a Calldown: MULE costs."""
LIFE_LOOPS = 1434.0
"""A MULE's life: 64 seconds at Faster speed (22.4 game loops a second)."""


def calldown_mule(units: Units, point, picked, next_tag):
    """`Effect_CalldownMULE_screen` at world `point` (float32[2]), on the unit `picked`
    (int32 slot under the click, or -1).

    Returns:
      (units, next_tag, result int32 `ActionResult`: NotEnoughEnergy without a selected
      Orbital Command of 50 energy, Error without a free slot).
    """
    n = units.num_slots
    rows = jnp.arange(n)
    casters = (commands.commandable(units) & units.complete
               & (units.type == UnitType.ORBITAL_COMMAND))
    caster = jnp.argmax(jnp.where(casters, units.energy, -1.0))
    slot = first_slots(open_slots(units), 1)[0]
    result = jnp.where(~casters.any() | (units.energy[caster] < ENERGY),
                       int(ActionResult.NotEnoughEnergy),
                       jnp.where(slot >= n, int(ActionResult.Error), 0)).astype(jnp.int32)
    safe = jnp.clip(picked, 0, n - 1)
    field = ((picked >= 0) & units.alive[safe] & (units.type[safe] == UnitType.MINERAL_FIELD)
             & (units.contents[safe] > 0))
    # On a field, at its edge towards the caster.
    away = units.pos[caster] - units.pos[safe]
    away = away / jnp.sqrt(jnp.maximum(squared_length(away), 1e-12))
    radius = jnp.asarray(UNIT_DATA.radius)
    beside = units.pos[safe] + away * (radius[units.type[safe]] + radius[UnitType.MULE])
    site = jnp.where(field, beside, point)
    new = (result == 0) & (rows == slot)
    placed = place_where(units, new, UnitType.MULE, Owner.SELF, site, next_tag)
    head = new[:, None] & (jnp.arange(units.orders.shape[1]) == 0)
    placed = placed.replace(
        life=jnp.where(new, LIFE_LOOPS, placed.life),
        orders=jnp.where(head & field, Order.GATHER, placed.orders),
        order_unit=jnp.where(head & field, picked, placed.order_unit),
        order_pos=jnp.where(head[..., None] & field, units.pos[safe], placed.order_pos),
        energy=jnp.where((result == 0) & (rows == caster), units.energy - ENERGY,
                         units.energy))
    return placed, next_tag + (result == 0).astype(jnp.int32), result


def expire(units: Units):
    """A game loop of the timed units' lives: those whose last loop it is die.

    Returns:
      (units, died bool[N]).
    """
    timed = units.alive & (units.life > 0)
    died = timed & (units.life <= 1.0)
    alive = units.alive & ~died
    return units.replace(
        life=jnp.where(timed, jnp.maximum(units.life - 1.0, 0.0), units.life), alive=alive,
        selected=units.selected & alive, groups=jnp.where(alive, units.groups, 0),
        orders=jnp.where(died[:, None], Order.NONE, units.orders),
        order_unit=jnp.where(died[:, None], NO_TARGET, units.order_unit)), died
