"""The user interface: selection, control groups and the camera.

Each function takes the units (and what it needs to see the screen) and returns the new
units or camera plus a success flag; a failed action changes nothing. The rules follow
the game's: only the player's own units can be selected together; a single enemy or
neutral unit can be selected alone (and then has no commands); a plain click where
nothing is drawn clears the selection, a toggle or add click there keeps it.
"""

from __future__ import annotations

import jax.numpy as jnp

from sc2jax.environment.engine.rules.geometry import squared_length
from sc2jax.environment.engine.rules.state import Owner, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, Attribute
from sc2jax.environment.interface import arguments as args_lib

NUM_GROUPS = 10


def _is_structure(units: Units):
    return (jnp.asarray(UNIT_DATA.attributes)[units.type] & Attribute.STRUCTURE) > 0


def selection_order(units: Units):
    """int32[N]: each selected unit's index in the multi-select panel (slot order)."""
    return jnp.cumsum(units.selected.astype(jnp.int32)) - 1


def select_point(units: Units, on_screen, picked, act):
    """Click selection.

    Args:
      units: the units.
      on_screen: bool[N] units visible on the screen.
      picked: int32 slot drawn at the clicked pixel, or -1.
      act: `SelectPointAct` (select, toggle, select_all_type, add_all_type).
    """
    n = units.num_slots
    own = units.alive & (units.owner == Owner.SELF)
    safe = jnp.clip(picked, 0, n - 1)
    hit = picked >= 0
    picked_own = hit & own[safe]
    only = (jnp.arange(n) == picked) & hit
    same_type = own & on_screen & (units.type == units.type[safe]) & picked_own
    current_own = units.selected & own
    toggled = jnp.where(only, ~units.selected, current_own)
    # Toggling or adding where nothing is drawn (a shift-click on the ground) keeps the
    # selection; a plain click there clears it.
    keep_if_missed = lambda x: jnp.where(hit, x, units.selected)  # noqa: E731
    choices = jnp.stack([
        only,
        keep_if_missed(jnp.where(picked_own, toggled, only)),
        jnp.where(picked_own, same_type, only),
        keep_if_missed(jnp.where(picked_own, current_own | same_type, only)),
    ])
    act = jnp.clip(act, 0, len(args_lib.SelectPointAct) - 1)
    return units.replace(selected=choices[act] & units.alive), jnp.bool_(True)


def select_rect(units: Units, pixel_pos, pixel_radius, on_screen, add, p0, p1):
    """Drag selection of own units whose circle meets the rectangle p0..p1 (inclusive
    pixels). Units are preferred over structures. With nothing own inside, it clears the
    selection (or keeps it when adding)."""
    lo = jnp.minimum(p0, p1).astype(jnp.float32)
    hi = jnp.maximum(p0, p1).astype(jnp.float32) + 1.0
    nearest = jnp.clip(pixel_pos, lo, hi)
    d2 = squared_length(nearest - pixel_pos)
    inside = units.alive & on_screen & (units.owner == Owner.SELF) & (
        d2 <= pixel_radius * pixel_radius)
    structures = _is_structure(units)
    mobile_inside = inside & ~structures
    chosen = jnp.where(mobile_inside.any(), mobile_inside, inside)
    current_own = units.selected & (units.owner == Owner.SELF)
    selected = jnp.where(add > 0, current_own | chosen, chosen)
    return units.replace(selected=selected & units.alive), jnp.bool_(True)


def select_army(units: Units, add):
    """Selects all of the player's army units (adding to own selected units if add)."""
    army = units.alive & (units.owner == Owner.SELF) & jnp.asarray(UNIT_DATA.is_army)[units.type]
    current_own = units.selected & (units.owner == Owner.SELF)
    return units.replace(selected=jnp.where(add > 0, current_own | army, army)), army.any()


def select_unit(units: Units, act, index):
    """Multi-select panel: act on the index-th selected unit (`SelectUnitAct`)."""
    n = units.num_slots
    order = selection_order(units)
    chosen = units.selected & (order == index)
    ok = chosen.any()
    slot = jnp.argmax(chosen)
    same_type = units.selected & (units.type == units.type[slot])
    choices = jnp.stack([
        chosen,
        units.selected & ~chosen,
        same_type,
        units.selected & ~same_type,
    ])
    act = jnp.clip(act, 0, len(args_lib.SelectUnitAct) - 1)
    selected = jnp.where(ok, choices[act], units.selected)
    del n
    return units.replace(selected=selected), ok


def control_group(units: Units, act, group_id):
    """Control groups (`ControlGroupAct`): recall, set, append, set_and_steal,
    append_and_steal."""
    bit = jnp.left_shift(jnp.int32(1), group_id)
    members = units.alive & ((units.groups & bit) != 0)
    own_selected = units.selected & (units.owner == Owner.SELF) & units.alive
    not_bit = jnp.bitwise_not(bit)
    all_bits = jnp.int32((1 << NUM_GROUPS) - 1)
    cleared = units.groups & not_bit
    set_groups = jnp.where(own_selected, cleared | bit, cleared)
    append_groups = jnp.where(own_selected, units.groups | bit, units.groups)
    stolen = jnp.where(own_selected, bit, units.groups & not_bit & all_bits)
    steal_append = jnp.where(own_selected, bit, units.groups)
    groups = jnp.stack([units.groups, set_groups, append_groups, stolen, steal_append])
    act = jnp.clip(act, 0, len(args_lib.ControlGroupAct) - 1)
    recall = act == args_lib.ControlGroupAct.recall
    ok = jnp.where(recall, members.any(), own_selected.any())
    selected = jnp.where(recall & ok, members, units.selected)
    new_groups = jnp.where(ok, groups[act], units.groups)
    return units.replace(selected=selected, groups=new_groups), ok


def select_idle_worker(units: Units, act):
    """`select_idle_worker`: select (or add) the next idle SCV after the selected ones
    (cycling), or all idle SCVs (`SelectWorker`: select, add, select_all, add_all)."""
    n = units.num_slots
    idle = units.idle_workers
    rows = jnp.arange(n)
    last = jnp.max(jnp.where(units.selected & idle, rows, -1))
    after = idle & (rows > last)
    chosen = jnp.argmax(jnp.where(after.any(), after, idle))
    one = idle & (rows == chosen)
    act = jnp.clip(act, 0, len(args_lib.SelectWorker) - 1)
    own_selected = units.selected & (units.owner == Owner.SELF)
    choices = jnp.stack([one, own_selected | one, idle, own_selected | idle])
    return units.replace(selected=choices[act] & units.alive), idle.any()
