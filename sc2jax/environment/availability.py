"""`available_actions`, computed from the selection by PySC2's rules.

UI functions are available by PySC2's conditions (reference/pysc2_facts.md §2.2); ability
functions are the union of the command cards of the player's selected units, exposed
through their general functions (PySC2's default `hide_specific_actions=True`).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.functions import FUNCTIONS, NUM_FUNCTIONS
from sc2jax.environment.state import Owner, Units
from sc2jax.environment.units import UNIT_DATA, UnitType

ALWAYS = ("no_op", "move_camera", "select_point", "select_rect", "select_control_group")

COMBAT_CARD = ("Attack_screen", "Attack_minimap", "HoldPosition_quick", "Move_screen",
               "Move_minimap", "Patrol_screen", "Patrol_minimap", "Smart_screen",
               "Smart_minimap", "Stop_quick")

COMMAND_CARDS: dict[UnitType, tuple[str, ...]] = {
    UnitType.MARINE: COMBAT_CARD,
    UnitType.ZERGLING: COMBAT_CARD,
    UnitType.ROACH: COMBAT_CARD,
    UnitType.BANELING: COMBAT_CARD,
    UnitType.SCV: COMBAT_CARD + ("Harvest_Gather_screen",),
}
"""Each unit type's command card, as general function names."""


def _card_table() -> np.ndarray:
    table = np.zeros((len(UnitType), NUM_FUNCTIONS), bool)
    for unit_type, names in COMMAND_CARDS.items():
        for name in names:
            table[unit_type, FUNCTIONS[name].id] = True
    return table


CARD_TABLE = _card_table()
"""bool[num_unit_types, num_functions]."""

_ALWAYS_MASK = np.zeros(NUM_FUNCTIONS, bool)
_ALWAYS_MASK[[FUNCTIONS[name].id for name in ALWAYS]] = True


def army_count(units: Units):
    own = units.alive & (units.owner == Owner.SELF)
    return jnp.sum(own & jnp.asarray(UNIT_DATA.is_army)[units.type]).astype(jnp.int32)


def available_actions(units: Units, idle_workers=0, card_table=CARD_TABLE):
    """bool[num_functions]: the functions the player may call.

    Args:
      units: the units.
      idle_workers: int32 number of idle workers (for `select_idle_worker`).
      card_table: the command cards in use (maps may restrict them).
    """
    own_selected = units.selected & units.alive & (units.owner == Owner.SELF)
    cards = jnp.asarray(card_table)[units.type]
    mask = jnp.any(cards & own_selected[:, None], axis=0) | jnp.asarray(_ALWAYS_MASK)
    multi = jnp.sum(units.selected & units.alive) > 1
    mask = mask.at[FUNCTIONS.select_unit.id].set(multi)
    mask = mask.at[FUNCTIONS.select_army.id].set(army_count(units) > 0)
    mask = mask.at[FUNCTIONS.select_idle_worker.id].set(idle_workers > 0)
    # Return Cargo is on the card of a worker that carries something.
    carrying = own_selected & (units.type == UnitType.SCV) & (units.cargo > 0)
    mask = mask.at[FUNCTIONS.Harvest_Return_quick.id].set(carrying.any())
    return mask
