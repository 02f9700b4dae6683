"""`available_actions`, computed from the selection by PySC2's rules.

UI functions are available by PySC2's conditions (reference/pysc2_facts.md §2.2); ability
functions are the union of the command cards of the player's selected units, exposed
through their general functions (PySC2's default `hide_specific_actions=True`).

PySC2 gives raw agents no available actions; sc2jax's padded observations give them
their `available_actions_mask` over the raw functions (`raw_available_actions`): a raw
function is available when its feature function would be with all the player's units
selected (the union of every own unit's card).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.rules import morphs, production, research
from sc2jax.environment.engine.rules.state import Owner, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType, game_name
from sc2jax.environment.interface.functions import (
    ALWAYS,
    FUNCTIONS,
    NUM_FUNCTIONS,
    RAW_FUNCTIONS,
)
from sc2jax.environment.interface.functions import FunctionType as T


def _make_function(unit_type: UnitType) -> str:
    """The PySC2 function that builds (an SCV) or trains (a structure) `unit_type`."""
    name = game_name(unit_type)
    return (f"Build_{name}_screen" if production.MAKES[UnitType.SCV, unit_type]
            else f"Train_{name}_quick")


MAKE_FUNCTIONS = {**{_make_function(UnitType(t)): UnitType(t)
                     for t in np.flatnonzero(production.MAKES.any(axis=0))},
                  **{name: UnitType(t) for name, (_, t) in morphs.UPGRADES.items()}}
"""Each Build_* or Train_* function the simulator has, and each upgrade queued as a unit
(`Morph_OrbitalCommand_quick`) -> the unit type it makes."""

COMBAT_CARD = ("Attack_screen", "Attack_minimap", "HoldPosition_quick", "Move_screen",
               "Move_minimap", "Patrol_screen", "Patrol_minimap", "Smart_screen",
               "Smart_minimap", "Stop_quick")

SCV_CARD = COMBAT_CARD + ("Harvest_Gather_screen", "Harvest_Return_quick",
                          "Build_SupplyDepot_screen", "Build_Barracks_screen",
                          "Build_Refinery_screen", "Build_CommandCenter_screen",
                          "Build_EngineeringBay_screen", "Build_Bunker_screen",
                          "Build_Factory_screen", "Build_Starport_screen")

MULE_CARD = ("HoldPosition_quick", "Move_screen", "Move_minimap", "Patrol_screen",
             "Patrol_minimap", "Smart_screen", "Smart_minimap", "Stop_quick",
             "Harvest_Gather_screen", "Harvest_Return_quick")
"""The MULE's card (its Repair is not modelled)."""

TOWN_HALL_CARD = ("Train_SCV_quick", "Rally_Workers_screen", "Rally_Workers_minimap",
                  "Smart_screen", "Smart_minimap", "Cancel_Last_quick")

ADDON_CARD = ("Build_TechLab_quick", "Build_Reactor_quick")

PRODUCER_CARD = ("Rally_Units_screen", "Rally_Units_minimap", "Smart_screen",
                 "Smart_minimap", "Cancel_Last_quick", "Lift_quick")

FLYING_CARD = ("Move_screen", "Move_minimap", "Stop_quick", "Smart_screen", "Smart_minimap",
               "Land_screen")
"""A flying structure's card (its Patrol, Hold, add-ons and rally are not modelled)."""

_RESEARCH_CARDS = {at: tuple(research.BUTTON[r] for r in research.Research
                              if research.AT[r] == at) + ("Cancel_Last_quick",)
                   for at in map(UnitType, sorted(set(research.AT.tolist())))}
"""The cards of the structures that research: their researches, and Cancel Last."""

COMMAND_CARDS: dict[UnitType, tuple[str, ...]] = {
    UnitType.MARINE: COMBAT_CARD + ("Effect_Stim_quick",),
    UnitType.MARAUDER: COMBAT_CARD + ("Effect_Stim_quick",),
    UnitType.ZERGLING: COMBAT_CARD,
    UnitType.ROACH: COMBAT_CARD,
    UnitType.BANELING: COMBAT_CARD,
    UnitType.REAPER: COMBAT_CARD,
    UnitType.HELLION: COMBAT_CARD,
    UnitType.VIKING_FIGHTER: COMBAT_CARD + ("Morph_VikingAssaultMode_quick",),
    UnitType.VIKING_ASSAULT: COMBAT_CARD + ("Morph_VikingFighterMode_quick",),
    UnitType.SIEGE_TANK: COMBAT_CARD + ("Morph_SiegeMode_quick",),
    UnitType.SIEGE_TANK_SIEGED: ("Attack_screen", "Attack_minimap", "Stop_quick",
                                 "Morph_Unsiege_quick"),
    UnitType.MEDIVAC: ("HoldPosition_quick", "Move_screen", "Move_minimap", "Patrol_screen",
                       "Patrol_minimap", "Smart_screen", "Smart_minimap", "Stop_quick"),
    UnitType.SCV: SCV_CARD,
    UnitType.MULE: MULE_CARD,
    UnitType.COMMAND_CENTER: TOWN_HALL_CARD + ("Morph_OrbitalCommand_quick", "Lift_quick"),
    UnitType.ORBITAL_COMMAND: TOWN_HALL_CARD + ("Lift_quick", "Effect_CalldownMULE_screen"),
    **{flying: FLYING_CARD for flying in (UnitType.COMMAND_CENTER_FLYING,
                                          UnitType.ORBITAL_COMMAND_FLYING,
                                          UnitType.BARRACKS_FLYING, UnitType.FACTORY_FLYING,
                                          UnitType.STARPORT_FLYING)},
    UnitType.SUPPLY_DEPOT: ("Morph_SupplyDepot_Lower_quick",),
    UnitType.SUPPLY_DEPOT_LOWERED: ("Morph_SupplyDepot_Raise_quick",),
    UnitType.BARRACKS: ("Train_Marine_quick", "Train_Reaper_quick", "Train_Marauder_quick")
    + ADDON_CARD + PRODUCER_CARD,
    UnitType.FACTORY: ("Train_Hellion_quick", "Train_SiegeTank_quick") + ADDON_CARD
    + PRODUCER_CARD,
    UnitType.STARPORT: ("Train_Medivac_quick", "Train_VikingFighter_quick") + ADDON_CARD
    + PRODUCER_CARD,
    **_RESEARCH_CARDS,
}
"""Each unit type's command card, as general function names, with the buttons the
simulator has (docs/fidelity.md). Some buttons show only when they apply
(`available_actions`): Return Cargo while carrying, Cancel Last while training, the
add-ons at a producer without one, a unit or structure once its requirement is met
(Build Barracks with a complete Supply Depot, Train Marauder at a Barracks with a
complete Tech Lab), a research while it is neither done nor queued, and Stim once
Stimpack is done."""

CONSTRUCTION_CARD = ("Cancel_quick",)
"""The card of an unfinished structure."""


def card_table(cards: dict[UnitType, tuple[str, ...]]) -> np.ndarray:
    """bool[num_unit_types, num_functions] from command cards (function names)."""
    table = np.zeros((len(UnitType), NUM_FUNCTIONS), bool)
    for unit_type, names in cards.items():
        for name in names:
            table[unit_type, FUNCTIONS[name].id] = True
    return table


CARD_TABLE = card_table(COMMAND_CARDS)
"""bool[num_unit_types, num_functions]."""

_REQUIRING = {name: t for name, t in MAKE_FUNCTIONS.items() if production.REQUIRED[t]}
_NEEDING_ADDON = {name: t for name, t in MAKE_FUNCTIONS.items() if production.NEEDS_ADDON[t]}
_CONSTRUCTION_MASK = card_table({UnitType.NONE: CONSTRUCTION_CARD})[UnitType.NONE]
_RESEARCH_FUNCTIONS = [FUNCTIONS[name].id for name in ("Effect_Stim_quick",
                                                        *research.BUTTON.values())]
_ALWAYS_MASK = np.zeros(NUM_FUNCTIONS, bool)
_ALWAYS_MASK[[FUNCTIONS[name].id for name in ALWAYS]] = True


def army_count(units: Units):
    own = units.alive & (units.owner == Owner.SELF)
    return jnp.sum(own & jnp.asarray(UNIT_DATA.is_army)[units.type]).astype(jnp.int32)


def idle_worker_count(units: Units):
    """int32: the player's idle SCVs."""
    return jnp.sum(units.idle_workers).astype(jnp.int32)


def _selected_types(units: Units, own_selected):
    """bool[num_unit_types]: the types of the complete units among `own_selected` (bool[N])."""
    of_type = units.type[:, None] == jnp.arange(len(UnitType), dtype=units.type.dtype)
    return jnp.any(of_type & (own_selected & units.complete)[:, None], axis=0)


def available_actions(units: Units, card_table=CARD_TABLE, researched=None):
    """bool[num_functions]: the functions the player may call.

    The command cards are united per selected unit type: the rows of the types that have
    a card, each kept where its type is selected, OR-ed one at a time (elementwise),
    where a gather of every unit's card row would cost [num_slots, num_functions]. (A
    [num_unit_types] x [num_unit_types, num_functions] product did the same, but under
    `vmap` XLA's CPU backend gives it to a library call.)

    Args:
      units: the units.
      card_table: bool[num_unit_types, num_functions] numpy array, the command cards in
        use (maps may restrict them).
      researched: bool[R] the player's research done (`EnvState.researched`), or None
        on maps without production, where nothing is researched: the research
        buttons and Stim are then never available.
    """
    own_selected = units.selected & units.alive & (units.owner == Owner.SELF)
    selected_types = _selected_types(units, own_selected)
    table = np.asarray(card_table, bool)
    cards = jnp.zeros(table.shape[1], bool)
    for unit_type in np.flatnonzero(table.any(axis=1)):
        cards = cards | (selected_types[unit_type] & jnp.asarray(table[unit_type]))
    constructing = jnp.any(own_selected & ~units.complete)
    mask = cards | (constructing & jnp.asarray(_CONSTRUCTION_MASK)) | jnp.asarray(_ALWAYS_MASK)
    count = jnp.sum(units.selected & units.alive)
    carrying = (own_selected & ((units.type == UnitType.SCV) | (units.type == UnitType.MULE))
                & (units.cargo > 0))
    queue = units.queue[:, 0] != 0
    training = own_selected & units.complete & queue
    # Single entries are set through constant one-hot masks, so that the whole mask is
    # one elementwise kernel, where an `.at[i].set` per entry is a kernel each (1.03x
    # the benchmark step at one environment, 1.015x at 64; docs/benchmarks.md).
    only = lambda name: jnp.asarray(np.arange(NUM_FUNCTIONS) == FUNCTIONS[name].id)  # noqa: E731
    # UI functions by the selection. `build_queue` is available while the production
    # panel shows (a single selected unit that is training).
    for name, value in {"select_unit": count > 1, "select_army": army_count(units) > 0,
                        "select_idle_worker": idle_worker_count(units) > 0,
                        "build_queue": (count == 1) & training.any()}.items():
        mask = jnp.where(only(name), value, mask)
    # Buttons that show only when they apply; a type's button once its requirement is
    # met.
    bare = (own_selected & units.complete & jnp.asarray(production.ADDON_OF[:, 1] > 0)[units.type]
            & (production.addon_kinds(units)[0] == 0))
    conditions = {"Harvest_Return_quick": carrying.any(), "Cancel_Last_quick": training.any(),
                  "Build_TechLab_quick": bare.any(), "Build_Reactor_quick": bare.any()}
    met = {}
    for name, unit_type in _REQUIRING.items():
        needed = int(production.REQUIRED[unit_type])
        if needed not in met:
            met[needed] = production.has_structure(units, needed)
        conditions[name] = met[needed]
    for name, unit_type in _NEEDING_ADDON.items():
        makers = own_selected & units.complete & jnp.asarray(production.MAKES[:, unit_type])[
            units.type]
        conditions[name] = conditions.get(name, True) & jnp.any(
            makers & production.equipped(units, unit_type))
    if researched is None:
        conditions.update({FUNCTIONS[i].name: False for i in _RESEARCH_FUNCTIONS})
    else:
        pending = production.pending(units, researched)
        conditions["Effect_Stim_quick"] = research.done(researched, research.Research.STIMPACK)
        for r, name in research.BUTTON.items():
            conditions[name] = ~pending[r]
    for name, condition in conditions.items():
        mask = mask & (~only(name) | condition)
    return mask


_FEATURE_TYPE = {T.raw_no_op: T.no_op, T.raw_move_camera: T.move_camera,
                 T.raw_cmd: T.cmd_quick, T.raw_cmd_pt: T.cmd_screen,
                 T.raw_cmd_unit: T.cmd_screen, T.raw_autocast: T.autocast}


def _feature_table() -> np.ndarray:
    """int32[len(RAW_FUNCTIONS)]: the feature function of each raw function, or -1."""
    by_ability = {}
    for f in FUNCTIONS:
        by_ability.setdefault((f.ability_id, f.function_type), f.id)
    by_ability[(0, T.no_op)] = FUNCTIONS.no_op.id
    by_ability[(0, T.move_camera)] = FUNCTIONS.move_camera.id
    return np.array([by_ability.get((r.ability_id, _FEATURE_TYPE[r.function_type]), -1)
                     for r in RAW_FUNCTIONS], np.int32)


FEATURE_OF_RAW = _feature_table()
"""int32[564]: the `FUNCTIONS` id that sends each raw function's ability in the same way
(-1 for the `UnloadUnit_*` functions, which have none)."""


def raw_available_actions(units: Units, card_table=CARD_TABLE, researched=None):
    """bool[564]: the raw functions the player may call, each available when its feature
    function (`FEATURE_OF_RAW`) is with every own unit selected (`available_actions`'
    arguments)."""
    everyone = units.replace(selected=units.alive & (units.owner == Owner.SELF))
    features = available_actions(everyone, card_table, researched)
    table = jnp.asarray(FEATURE_OF_RAW)
    return (table >= 0) & features[jnp.maximum(table, 0)]
