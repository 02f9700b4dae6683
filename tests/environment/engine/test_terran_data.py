"""The Terran data table against independent sources, and the engine's unit data against
the table."""

import json
import pathlib

import numpy as np
import pytest

from sc2jax.environment.engine import terran_data
from sc2jax.environment.engine.rules.units import (
    LOOPS_PER_SECOND,
    UNIT_DATA,
    Attribute,
    Targets,
    terran_types,
)
from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.replay_sl.units import stable_unit_ids

UNITS = terran_data.table()["units"]
UPGRADES = terran_data.table()["upgrades"]

# Issue 64's Terran game: every unit, building and research it names.
ISSUE_UNITS = ("SCV", "MULE", "Marine", "Marauder", "Reaper", "Hellion", "SiegeTank",
               "SiegeTankSieged", "Medivac", "VikingFighter", "VikingAssault")
ISSUE_BUILDINGS = ("CommandCenter", "OrbitalCommand", "SupplyDepot", "SupplyDepotLowered",
                   "Refinery", "Barracks", "Factory", "Starport", "BarracksTechLab",
                   "BarracksReactor", "FactoryTechLab", "FactoryReactor", "StarportTechLab",
                   "StarportReactor", "EngineeringBay", "Bunker", "CommandCenterFlying",
                   "OrbitalCommandFlying", "BarracksFlying", "FactoryFlying",
                   "StarportFlying")
ISSUE_RESEARCH = ("Stimpack", "ShieldWall", "PunisherGrenades",
                  "TerranInfantryWeaponsLevel1", "TerranInfantryArmorsLevel1")


def test_the_table_holds_the_issues_terran_game():
    assert sorted(UNITS) == sorted(ISSUE_UNITS + ISSUE_BUILDINGS)
    assert sorted(UPGRADES) == sorted(ISSUE_RESEARCH)


def test_ids_agree_with_blizzards_stable_ids():
    stable = stable_unit_ids()
    assert {name: row["sc2_id"] for name, row in UNITS.items()} == {
        name: stable[name] for name in UNITS}
    upgrades = json.loads((pathlib.Path(terran_data.__file__).parents[2] / "replay_sl" / "data"
                           / "stableid.json").read_text())["Upgrades"]
    upgrade_ids = {u["name"]: u["id"] for u in upgrades}
    assert {name: row["upgrade_id"] for name, row in UPGRADES.items()} == {
        name: upgrade_ids[name] for name in UPGRADES}


def test_each_make_ability_is_pysc2s_function_for_it():
    """The API dump's ability per type (train, build, morph, lift) is the ability of the
    PySC2 function named for it: two independent sources agree."""
    by_ability = {}
    for f in FUNCTIONS:
        if f.ability_id:
            by_ability.setdefault(f.ability_id, []).append(f.name)
    expected = {"SCV": "Train_SCV", "Marine": "Train_Marine", "Marauder": "Train_Marauder",
                "Reaper": "Train_Reaper", "Hellion": "Train_Hellion",
                "SiegeTank": "Train_SiegeTank", "SiegeTankSieged": "Morph_SiegeMode",
                "Medivac": "Train_Medivac", "VikingFighter": "Train_VikingFighter",
                "VikingAssault": "Morph_VikingAssaultMode",
                "CommandCenterFlying": "Lift_CommandCenter",
                "OrbitalCommand": "Morph_OrbitalCommand",
                "OrbitalCommandFlying": "Lift_OrbitalCommand",
                "SupplyDepotLowered": "Morph_SupplyDepot_Lower",
                "BarracksFlying": "Lift_Barracks", "FactoryFlying": "Lift_Factory",
                "StarportFlying": "Lift_Starport",
                "BarracksTechLab": "Build_TechLab_Barracks",
                "BarracksReactor": "Build_Reactor_Barracks",
                "FactoryTechLab": "Build_TechLab_Factory",
                "FactoryReactor": "Build_Reactor_Factory",
                "StarportTechLab": "Build_TechLab_Starport",
                "StarportReactor": "Build_Reactor_Starport"}
    for name in ("CommandCenter", "SupplyDepot", "Refinery", "Barracks", "Factory",
                 "Starport", "EngineeringBay", "Bunker"):
        expected[name] = f"Build_{name}"
    for name, function in expected.items():
        names = by_ability[UNITS[name]["ability_id"]]
        assert any(n.rsplit("_", 1)[0] == function for n in names), (name, names)
    assert UNITS["MULE"]["ability_id"] == 0  # Called down, not trained.


def test_producers_requirements_and_morphs_name_types_of_the_table():
    for name, row in UNITS.items():
        assert bool(row["producers"]) != (row["morphs_from"] is not None), name
        for other in row["producers"] + [row["morphs_from"], row["requires"]]:
            assert other is None or other in UNITS, (name, other)
        assert row["requires_addon"] in (None, "TechLab"), name
        assert row["tech_alias"] in (None, "TechLab", "Reactor") or row["tech_alias"] in UNITS
    for name, row in UPGRADES.items():
        assert row["researched_at"] in UNITS, name


def test_every_value_names_its_source():
    sources = terran_data.table()["sources"]
    for row in list(UNITS.values()) + list(UPGRADES.values()):
        fields = set(row) - {"source"}
        assert set(row["source"]) == fields
        assert set(row["source"].values()) <= set(sources)


@pytest.mark.parametrize("name", sorted(ISSUE_UNITS + ISSUE_BUILDINGS))
def test_engine_unit_data_is_the_tables(name):
    row = UNITS[name]
    t = terran_types()[name]
    weapon = row["weapons"][0] if row["weapons"] else None
    assert UNIT_DATA.sc2_id[t] == row["sc2_id"]
    assert (UNIT_DATA.mineral_cost[t], UNIT_DATA.vespene_cost[t]) == (
        row["minerals"], row["vespene"])
    np.testing.assert_equal(
        [UNIT_DATA.build_time[t], UNIT_DATA.food[t], UNIT_DATA.supply[t],
         UNIT_DATA.max_health[t], UNIT_DATA.armor[t], UNIT_DATA.radius[t],
         UNIT_DATA.sight[t], UNIT_DATA.max_energy[t], UNIT_DATA.start_energy[t]],
        np.float32([row["build_time"], row["food"], row["supply"], row["health"],
                    row["armor"], row["radius"], row["sight"], row["max_energy"],
                    row["start_energy"]]))
    np.testing.assert_allclose(UNIT_DATA.speed[t] * LOOPS_PER_SECOND, row["speed"])
    assert bool(UNIT_DATA.flying[t]) == row["flying"]
    assert tuple(UNIT_DATA.footprint[t]) == tuple(row["footprint"])
    for attribute in ("Light", "Armored", "Biological", "Mechanical", "Structure"):
        has = (UNIT_DATA.attributes[t] & Attribute[attribute.upper()]) > 0
        assert has == (attribute in row["attributes"]), attribute
    if weapon is None:
        assert UNIT_DATA.damage[t] == 0 and UNIT_DATA.attacks[t] == 0
        return
    np.testing.assert_allclose(
        [UNIT_DATA.damage[t], UNIT_DATA.bonus[t], UNIT_DATA.range[t],
         UNIT_DATA.cooldown[t] / LOOPS_PER_SECOND],
        [weapon["damage"], weapon["bonus"], weapon["range"], weapon["cooldown"]], rtol=1e-6)
    assert UNIT_DATA.attacks[t] == weapon["attacks"]
    assert Targets(int(UNIT_DATA.targets[t])) == {
        "Ground": Targets.GROUND, "Air": Targets.AIR,
        "Any": Targets.GROUND | Targets.AIR}[weapon["targets"]]
    bonus = weapon["bonus_attribute"]
    assert UNIT_DATA.bonus_attribute[t] == (Attribute[bonus.upper()] if bonus else 0)


def test_values_a_second_source_confirms():
    """Values Liquipedia's Legacy of the Void pages give too (times in whole seconds at
    Faster speed, 22.4 game loops each)."""
    liquipedia = {  # name: (health, minerals, vespene, build seconds at Faster)
        "Marine": (45, 50, 0, 18), "SiegeTank": (175, 150, 125, 32),
        "Medivac": (150, 100, 100, 30), "SupplyDepot": (400, 100, 0, 21),
        "Refinery": (500, 75, 0, 21), "BarracksTechLab": (400, 50, 25, 18),
        "EngineeringBay": (850, 125, 0, 25), "Bunker": (400, 100, 0, 29)}
    for name, (health, minerals, vespene, seconds) in liquipedia.items():
        row = UNITS[name]
        assert (row["health"], row["minerals"], row["vespene"]) == (health, minerals, vespene)
        assert round(row["build_time"] / (LOOPS_PER_SECOND * 1.4)) == seconds, name
    assert (UNITS["Medivac"]["max_energy"], UNITS["Medivac"]["start_energy"]) == (200, 50)
    assert UNITS["MULE"]["health"] == 60
