"""Unit commands: orders given to the selected units, now or queued.

A command given now replaces a unit's order queue; a queued command is appended (and
starts at once if the unit is idle). Units whose queue is full ignore a queued command.
"""

from __future__ import annotations

import jax.numpy as jnp

from sc2jax.environment.engine.rules.state import NO_TARGET, ORDER_QUEUE, Order, Owner, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType


def commandable(units: Units):
    """bool[N]: the player's selected living units."""
    return units.selected & units.alive & (units.owner == Owner.SELF)


def obeys(units: Units, order):
    """bool[N]: units able to carry out an order type (movers move, armed units attack,
    workers harvest and build)."""
    speed = jnp.asarray(UNIT_DATA.speed)[units.type]
    damage = jnp.asarray(UNIT_DATA.damage)[units.type]
    moves = speed > 0
    armed = damage > 0
    needs_weapon = (order == Order.ATTACK_UNIT) | (order == Order.ATTACK_MOVE)
    harvests = ((order == Order.GATHER) | (order == Order.RETURN) | (order == Order.BUILD)
                | (order == Order.CONSTRUCT))
    return jnp.where(harvests, units.type == UnitType.SCV, jnp.where(
        needs_weapon | (order == Order.HOLD), moves | armed, moves))


def issue(units: Units, order, queued, point, target_unit=NO_TARGET, unit_type=0):
    """Gives an order to the selected units.

    Args:
      units: the units.
      order: int32 `Order` (MOVE, ATTACK_MOVE, ATTACK_UNIT, PATROL, HOLD, GATHER,
        RETURN, BUILD, CONSTRUCT, LAND).
      queued: int32 0 (now) or 1 (queued).
      point: float32[2] world target point.
      target_unit: int32 target slot for ATTACK_UNIT, GATHER and CONSTRUCT (-1 for
        RETURN: the nearest Command Center), else -1.
      unit_type: int32 the `UnitType` a BUILD order places or a LAND order lands as,
        else 0.

    Returns:
      (units, ok): ok is False if no selected unit could take the order.
    """
    who = commandable(units) & obeys(units, order)
    free = units.orders == Order.NONE
    first_free = jnp.argmax(free, axis=1)
    has_room = free.any(axis=1)
    slot = jnp.where(queued > 0, first_free, 0)
    takes = who & jnp.where(queued > 0, has_room, True)
    q = jnp.arange(ORDER_QUEUE)
    at_slot = (q[None, :] == slot[:, None]) & takes[:, None]
    replace = takes & (queued == 0)
    after = replace[:, None] & (q[None, :] > 0)
    orders = jnp.where(at_slot, order, jnp.where(after, Order.NONE, units.orders))
    order_pos = jnp.where(at_slot[..., None], point, jnp.where(after[..., None], 0.0,
                                                                units.order_pos))
    order_unit = jnp.where(at_slot, target_unit, jnp.where(after, NO_TARGET, units.order_unit))
    order_type = jnp.where(at_slot, unit_type, jnp.where(after, 0, units.order_type))
    starts_now = takes & (slot == 0)
    units = units.replace(
        orders=orders, order_pos=order_pos, order_unit=order_unit, order_type=order_type,
        patrol_origin=jnp.where(starts_now[:, None], units.pos, units.patrol_origin),
        work=jnp.where(starts_now, 0.0, units.work),
        target=jnp.where(starts_now, jnp.where(order == Order.ATTACK_UNIT, target_unit,
                                               NO_TARGET), units.target))
    return units, takes.any()


def stop(units: Units):
    """Clears the selected units' orders and targets."""
    who = commandable(units)
    units = units.replace(
        orders=jnp.where(who[:, None], Order.NONE, units.orders),
        order_unit=jnp.where(who[:, None], NO_TARGET, units.order_unit),
        order_type=jnp.where(who[:, None], 0, units.order_type),
        work=jnp.where(who, 0.0, units.work),
        target=jnp.where(who, NO_TARGET, units.target))
    return units, who.any()
