"""CollectMineralsAndGas and BuildMarines: a Command Center, 12 SCVs and resources.

Both maps' scripts (MapScript.galaxy, Objects and Regions; reference/pysc2_facts.md §4):

- a Command Center at (29.8251, 28.0083); 12 SCVs in two columns beside it, at x offsets
  ±4.5 and ±3.5 (the side drawn at random) and y offsets 2.5, 1.5, ... -2.5; 50 minerals;
  the camera on the centre of the playable area (19.94, 19.00)-(45.94, 37.00), 3 below;
- CollectMineralsAndGas (420 s): 16 mineral fields (1800 each) in two lines at x 23-25
  and 41-43, and 4 Vespene Geysers (2250 each) at (26.5 | 39.5, 20.5 | 34.5); the SCVs
  start idle; the score is the minerals plus vespene collected (spending does not lower
  it), updated every loop;
- BuildMarines (900 s): the left line of 8 mineral fields only; the SCVs start
  harvesting the field at (23, 26.5) and the Command Center is rallied to it; +1 for
  every Marine created; the command cards are cut down to the map's (`BUILD_MARINES_CARDS`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.availability import COMBAT_CARD, card_table
from sc2jax.environment.engine.minigames.base import MiniGame, flat_geometry
from sc2jax.environment.engine.rules.state import Order, Owner, Units, place
from sc2jax.environment.engine.rules.units import UnitType, terran_types
from sc2jax.environment.interface.observation_tables import ScoreCumulative

REGION_1 = (19.9362, 18.998, 45.936, 36.998)
CAMERA = (32.9361, 24.998)  # centre(region 1) + 3 at 270 degrees.
COMMAND_CENTER = (29.8251, 28.0083)
STARTING_MINERALS = 50
# The SCVs' offsets from the Command Center (x for the +1 side), in creation order.
SCV_OFFSETS = np.array([(x, y) for y in (2.5, 1.5, 0.5, -0.5, -1.5, -2.5) for x in (4.5, 3.5)],
                       np.float32)
LEFT_FIELDS = np.array([(23, 28.5), (24, 29.5), (23, 26.5), (25, 22.5), (25, 32.5),
                        (24, 23.5), (24, 31.5), (24, 25.5)], np.float32)
RIGHT_FIELDS = np.array([(41, 22.5), (42, 25.5), (42, 23.5), (41, 32.5), (43, 26.5),
                         (43, 28.5), (42, 29.5), (42, 31.5)], np.float32)
GEYSERS = np.array([(39.5, 20.5), (26.5, 34.5), (39.5, 34.5), (26.5, 20.5)], np.float32)
HARVESTED_FIELD = 2
"""BuildMarines: the index in LEFT_FIELDS of the field at (23, 26.5) the SCVs start on."""

BUILD_MARINES_CARDS = {
    UnitType.SCV: ("Smart_screen", "Smart_minimap", "Harvest_Gather_screen",
                   "Harvest_Return_quick", "Build_SupplyDepot_screen", "Build_Barracks_screen"),
    UnitType.COMMAND_CENTER: ("Train_SCV_quick", "Rally_Workers_screen", "Rally_Workers_minimap",
                              "Smart_screen", "Smart_minimap"),
    UnitType.BARRACKS: ("Train_Marine_quick", "Smart_screen", "Smart_minimap"),
    UnitType.MARINE: COMBAT_CARD,
}
"""BuildMarines' command cards, from the map's UnitData.xml: the SCV keeps Gather, Return
Cargo and a Build menu of Supply Depot and Barracks; the Command Center Train SCV and
Rally; the Barracks Train Marine; the Supply Depot nothing; the Marine loses only
Stimpack (not modelled). Smart (the right click) is on no card and stays."""

_UNIT_TYPES = (UnitType.SCV, UnitType.MARINE, UnitType.MINERAL_FIELD, UnitType.VESPENE_GEYSER,
               UnitType.COMMAND_CENTER, UnitType.SUPPLY_DEPOT, UnitType.BARRACKS,
               UnitType.REFINERY)
"""BuildMarines' unit types: what its cut-down cards can make."""


class EconomyGame(MiniGame):
    """The shared start: resources in the first slots, then the Command Center, then the
    SCVs; the rest of the slots are free for what the player trains and builds.

    Class attributes:
      FIELDS: float32[F, 2] mineral field positions.
      GEYSERS: float32[G, 2] geyser positions.
      UNIT_TYPES: every type the map can hold.
    """

    FIELDS: np.ndarray = np.zeros((0, 2), np.float32)
    GEYSERS: np.ndarray = np.zeros((0, 2), np.float32)
    UNIT_TYPES: tuple[UnitType, ...] = _UNIT_TYPES

    def __init__(self, name, time_limit, num_slots, slot_sizes):
        super().__init__(name=name, time_limit=time_limit, num_slots=num_slots,
                         geometry=flat_geometry(REGION_1), fog=False, camera=CAMERA,
                         unit_types=self.UNIT_TYPES, starting_minerals=STARTING_MINERALS,
                         has_enemies=False, field_slots=len(self.FIELDS), slot_sizes=slot_sizes)

    @property
    def command_center(self) -> int:
        return len(self.FIELDS) + len(self.GEYSERS)

    @property
    def scvs(self) -> np.ndarray:
        return self.command_center + 1 + np.arange(len(SCV_OFFSETS))

    def init(self, key):
        units = Units.empty(self.num_slots)
        fields = np.arange(len(self.FIELDS))
        units, tag = place(units, fields, UnitType.MINERAL_FIELD, Owner.NEUTRAL,
                           jnp.asarray(self.FIELDS), 0)
        if len(self.GEYSERS):
            units, tag = place(units, len(self.FIELDS) + np.arange(len(self.GEYSERS)),
                               UnitType.VESPENE_GEYSER, Owner.NEUTRAL,
                               jnp.asarray(self.GEYSERS), tag)
        cc = jnp.asarray(COMMAND_CENTER, jnp.float32)
        units, tag = place(units, np.array([self.command_center]), UnitType.COMMAND_CENTER,
                           Owner.SELF, cc[None], tag)
        side = jnp.where(jax.random.bernoulli(key), 1.0, -1.0)
        offsets = jnp.asarray(SCV_OFFSETS) * jnp.array([side, 1.0])
        units, tag = place(units, self.scvs, UnitType.SCV, Owner.SELF, cc + offsets, tag)
        return units, (), tag


class CollectMineralsAndGas(EconomyGame):
    FIELDS = np.concatenate([LEFT_FIELDS, RIGHT_FIELDS])
    GEYSERS = GEYSERS
    # Its cards are the game's: every Terran type can be made (an Orbital Command's
    # energy, a flying Barracks).
    UNIT_TYPES = (UnitType.MINERAL_FIELD, UnitType.VESPENE_GEYSER,
                  *sorted(terran_types().values()))

    def __init__(self):
        # 33 units at the start, at most 56 alive in four of the scripted agent's episodes.
        super().__init__("CollectMineralsAndGas", time_limit=420, num_slots=96,
                         slot_sizes=(48, 96))

    def on_loop(self, state, events):
        collected = (state.score_cumulative[ScoreCumulative.collected_minerals]
                     + state.score_cumulative[ScoreCumulative.collected_vespene])
        return state.replace(score=collected)


class BuildMarines(EconomyGame):
    FIELDS = LEFT_FIELDS

    def __init__(self):
        # 21 units at the start, about 190 at the scripted agent's end.
        super().__init__("BuildMarines", time_limit=900, num_slots=200,
                         slot_sizes=(32, 96, 200))

    @property
    def card_table(self) -> np.ndarray:
        return card_table(BUILD_MARINES_CARDS)

    def init(self, key):
        units, map_state, tag = super().init(key)
        field = HARVESTED_FIELD
        scvs = jnp.asarray(self.scvs)
        cc = self.command_center
        units = units.replace(
            orders=units.orders.at[scvs, 0].set(Order.GATHER),
            order_unit=units.order_unit.at[scvs, 0].set(field),
            order_pos=units.order_pos.at[scvs, 0].set(units.pos[field]),
            rally=units.rally.at[cc].set(units.pos[field]),
            rally_unit=units.rally_unit.at[cc].set(field),
            rallied=units.rallied.at[cc].set(True))
        return units, map_state, tag

    def on_loop(self, state, events):
        marines = jnp.sum(events.created & (state.units.type == UnitType.MARINE))
        return state.replace(score=state.score + marines.astype(jnp.int32))
