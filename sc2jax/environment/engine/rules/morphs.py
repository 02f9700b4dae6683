"""Morphs: a unit or structure turning into another form of itself, in its slot.

The forms and their morph times come from the Terran data table (`terran_data`: the
forms with a `morphs_from`); the ability of each is a PySC2 function.

- **Modes**: Lower and Raise a Supply Depot, Siege Mode and Unsiege a Siege Tank,
  Assault and Fighter Mode a Viking. The selected units of the form switch at once (the
  unit stops), and spend the morph time with their weapon cooling down: a sieged tank
  fires its first shot once the morph is done. The table holds the forward morph's time
  (lowering, sieging, landing a Viking); the way back takes the same.
- **Upgrades** with a cost: the Command Center to an Orbital Command. It is trained by
  the structure as a unit is (`production`: paid when queued, refunded when cancelled,
  in its morph time), at an idle structure that then trains nothing else; when done the
  structure becomes the new form, with the new form's starting energy.

Lifting off and landing, to and from the flying forms, are `liftoff`'s.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine import terran_data
from sc2jax.environment.engine.rules import commands, research
from sc2jax.environment.engine.rules.state import NO_TARGET, Order, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType, terran_types
from sc2jax.environment.interface.functions import FUNCTIONS

_BACK = {"SupplyDepotLowered": "Morph_SupplyDepot_Raise_quick",
         "SiegeTankSieged": "Morph_Unsiege_quick",
         "VikingAssault": "Morph_VikingFighterMode_quick"}
"""The function morphing each mode back to its first form."""


def _tables():
    types = terran_types()
    by_ability = {f.ability_id: f.name for f in FUNCTIONS if f.ability_id}
    modes, upgrades = {}, {}
    for name, t in types.items():
        row = terran_data.unit(name)
        source = row["morphs_from"]
        if not source or name.endswith("Flying"):
            continue  # Lifting off is not modelled yet.
        loops = float(row["build_time"])
        if name in _BACK:
            modes[by_ability[row["ability_id"]]] = (types[source], t, loops)
            modes[_BACK[name]] = (t, types[source], loops)
        else:
            upgrades[by_ability[row["ability_id"]]] = (types[source], t)
    return modes, upgrades


MODES, UPGRADES = _tables()
"""MODES: function name -> (from, to, morph loops) of the switches. UPGRADES: function
name -> (from, to) of the morphs a structure trains."""

UPGRADE = np.zeros((len(UnitType), research.NUM_ITEMS), bool)
"""bool[T, I], [from, item]: a structure of type `from` trains the upgrade to the type
`item` (a queue item, `research.FIRST` of them unit types)."""
for _source, _target in UPGRADES.values():
    UPGRADE[_source, _target] = True

_FROM = np.zeros(len(FUNCTIONS), np.int32)
_TO = np.zeros(len(FUNCTIONS), np.int32)
_LOOPS = np.zeros(len(FUNCTIONS), np.float32)
for _name, (_source, _target, _loops) in MODES.items():
    _FROM[FUNCTIONS[_name].id], _TO[FUNCTIONS[_name].id] = _source, _target
    _LOOPS[FUNCTIONS[_name].id] = _loops


def switch_mode(units: Units, function):
    """A mode switch (`MODES`; `function` int32 its PySC2 id): the player's selected
    complete units of its first form become the second at once, stop, and hold their
    fire for the morph time.

    Returns:
      (units, ok bool: any switched).
    """
    source, target = jnp.asarray(_FROM)[function], jnp.asarray(_TO)[function]
    switching = (commands.commandable(units) & units.complete & (units.type == source)
                 & (source > 0))
    rows = switching[:, None]
    return units.replace(
        type=jnp.where(switching, target, units.type),
        progress=jnp.where(switching, jnp.asarray(UNIT_DATA.build_time)[target],
                           units.progress),
        cooldown=jnp.where(switching, jnp.maximum(units.cooldown,
                                                  jnp.asarray(_LOOPS)[function]),
                           units.cooldown),
        orders=jnp.where(rows, Order.NONE, units.orders),
        order_unit=jnp.where(rows, NO_TARGET, units.order_unit),
        target=jnp.where(switching, NO_TARGET, units.target)), switching.any()


def upgrade_done(units: Units, done):
    """The structures where bool[N] `done` holds, their upgrade at the queue's head
    finished, become its form (complete, with at least its starting energy)."""
    target = jnp.where(done, units.queue[:, 0], units.type)
    return units.replace(
        type=target,
        progress=jnp.where(done, jnp.asarray(UNIT_DATA.build_time)[target], units.progress),
        energy=jnp.where(done, jnp.maximum(units.energy,
                                           jnp.asarray(UNIT_DATA.start_energy)[target]),
                         units.energy))
