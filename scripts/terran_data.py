r"""Writes the packaged Terran data table (`environment.engine.terran_data`).

    pip download --no-deps -d /tmp/sc2data daSC2==0.2.2.dev3
    tar xzf /tmp/sc2data/daSC2-0.2.2.dev3.tar.gz -C /tmp/sc2data
    python scripts/terran_data.py \
        --dasc2_units=/tmp/sc2data/daSC2-0.2.2.dev3/dasc2/data/units.json

The game's own data files cannot be installed here, so the table merges what public
dumps of the game's API give, each value marked with its source (`SOURCES`):

- "api-4.1": daSC2's `units.json`, the game API's `UnitTypeData` at build 60321 (4.1.1):
  ids, costs, food, build and morph times, armour, speed, sight, attributes, weapons,
  tech requirements.
- "api-2021": fields the 4.1 dump lacks (health, radius, energy, cargo, flying), and the
  upgrades' costs and research times, from an API dump of 2021 (BurnySc2/sc2-techtree
  `data/data.json` at commit 1d7643a), transcribed below (`LATER_API`, `UPGRADES`).
- "burnysc2": who trains, builds or morphs each type (burnysc2 7.3.0 `sc2/dicts`).
- "footprint": the placement footprints, the editor's standard sizes (not in either dump).

It writes sc2jax/environment/engine/data/terran.json, atomically. With --markdown it
prints the packaged table as docs/full_game.md shows it instead.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import re

from sc2jax.atomic import atomic_write
from sc2jax.environment.engine import terran_data

OUTPUT = pathlib.Path(terran_data.__file__).parent / terran_data.DATA

SOURCES = {
    "api-4.1": "daSC2 0.2.2.dev3 dasc2/data/units.json (PyPI, Apache-2.0): the game API's "
               "UnitTypeData at build 60321 (4.1.1)",
    "api-2021": "BurnySc2/sc2-techtree data/data.json at commit 1d7643a (MIT): the game "
                "API's unit and upgrade data, 2021 (5.0.x)",
    "spawningtool": "spawningtool 3.0.0 lotv_constants.py BUILD_TIME_CHANGES (PyPI, MIT): "
                    "Stimpack 121 -> 100 s in the balance update of 2019-08-21",
    "burnysc2": "burnysc2 7.3.0 sc2/dicts/unit_trained_from.py and "
                "unit_train_build_abilities.py (PyPI, MIT)",
    "footprint": "the editor's standard footprints (Footprint5x5, 3x3 and 2x2 with "
                 "add-on contour), from knowledge of the game; not in either API dump",
}

# Type -> (the types that train, build or call it down, the structure it needs, the add-on
# its producer needs, what it morphs from).
TECH = {
    "SCV": (("CommandCenter", "OrbitalCommand"), None, None, None),
    "MULE": (("OrbitalCommand",), None, None, None),
    "Marine": (("Barracks",), None, None, None),
    "Marauder": (("Barracks",), None, "TechLab", None),
    "Reaper": (("Barracks",), None, None, None),
    "Hellion": (("Factory",), None, None, None),
    "SiegeTank": (("Factory",), None, "TechLab", None),
    "SiegeTankSieged": ((), None, None, "SiegeTank"),
    "Medivac": (("Starport",), None, None, None),
    "VikingFighter": (("Starport",), None, None, None),
    "VikingAssault": ((), None, None, "VikingFighter"),
    "CommandCenter": (("SCV",), None, None, None),
    "CommandCenterFlying": ((), None, None, "CommandCenter"),
    "OrbitalCommand": ((), "Barracks", None, "CommandCenter"),
    "OrbitalCommandFlying": ((), None, None, "OrbitalCommand"),
    "SupplyDepot": (("SCV",), None, None, None),
    "SupplyDepotLowered": ((), None, None, "SupplyDepot"),
    "Refinery": (("SCV",), None, None, None),
    "Barracks": (("SCV",), "SupplyDepot", None, None),
    "BarracksFlying": ((), None, None, "Barracks"),
    "Factory": (("SCV",), "Barracks", None, None),
    "FactoryFlying": ((), None, None, "Factory"),
    "Starport": (("SCV",), "Factory", None, None),
    "StarportFlying": ((), None, None, "Starport"),
    "BarracksTechLab": (("Barracks",), None, None, None),
    "BarracksReactor": (("Barracks",), None, None, None),
    "FactoryTechLab": (("Factory",), None, None, None),
    "FactoryReactor": (("Factory",), None, None, None),
    "StarportTechLab": (("Starport",), None, None, None),
    "StarportReactor": (("Starport",), None, None, None),
    "EngineeringBay": (("SCV",), "CommandCenter", None, None),
    "Bunker": (("SCV",), "Barracks", None, None),
}

# From the 2021 API dump: (health, radius, max energy, start energy, cargo capacity, flying).
LATER_API = {
    "SCV": (45, 0.375, 0, 0, 0, False),
    "MULE": (60, 0.375, 0, 0, 0, False),
    "Marine": (45, 0.375, 0, 0, 0, False),
    "Marauder": (125, 0.5625, 0, 0, 0, False),
    "Reaper": (60, 0.375, 0, 0, 0, False),
    "Hellion": (90, 0.625, 0, 0, 0, False),
    "SiegeTank": (175, 0.875, 0, 0, 0, False),
    "SiegeTankSieged": (175, 0.875, 0, 0, 0, False),
    "Medivac": (150, 0.75, 200, 50, 8, True),
    "VikingFighter": (135, 0.75, 0, 0, 0, True),
    "VikingAssault": (135, 0.75, 0, 0, 0, False),
    "CommandCenter": (1500, 2.75, 0, 0, 5, False),
    "CommandCenterFlying": (1500, 2.5, 0, 0, 5, True),
    "OrbitalCommand": (1500, 2.75, 200, 50, 0, False),
    "OrbitalCommandFlying": (1500, 2.5, 200, 50, 0, True),
    "SupplyDepot": (400, 1.25, 0, 0, 0, False),
    "SupplyDepotLowered": (400, 1.25, 0, 0, 0, False),
    "Refinery": (500, 1.6875, 0, 0, 0, False),
    "Barracks": (1000, 1.8125, 0, 0, 0, False),
    "BarracksFlying": (1000, 1.75, 0, 0, 0, True),
    "Factory": (1250, 1.8125, 0, 0, 0, False),
    "FactoryFlying": (1250, 1.625, 0, 0, 0, True),
    "Starport": (1300, 1.8125, 0, 0, 0, False),
    "StarportFlying": (1300, 1.625, 0, 0, 0, True),
    "BarracksTechLab": (400, 1.125, 0, 0, 0, False),
    "BarracksReactor": (400, 1.125, 0, 0, 0, False),
    "FactoryTechLab": (400, 1.125, 0, 0, 0, False),
    "FactoryReactor": (400, 1.125, 0, 0, 0, False),
    "StarportTechLab": (400, 1.125, 0, 0, 0, False),
    "StarportReactor": (400, 1.125, 0, 0, 0, False),
    "EngineeringBay": (850, 1.8125, 0, 0, 0, False),
    "Bunker": (400, 1.8125, 0, 0, 4, False),
}

# Placement footprints (width, height) in cells; landed production buildings also need
# their add-on's 2 x 2 to the right.
FOOTPRINTS = {"CommandCenter": (5, 5), "OrbitalCommand": (5, 5), "SupplyDepot": (2, 2),
              "SupplyDepotLowered": (2, 2), "Refinery": (3, 3), "Barracks": (3, 3),
              "Factory": (3, 3), "Starport": (3, 3), "EngineeringBay": (3, 3),
              "Bunker": (3, 3), "BarracksTechLab": (2, 2), "BarracksReactor": (2, 2),
              "FactoryTechLab": (2, 2), "FactoryReactor": (2, 2), "StarportTechLab": (2, 2),
              "StarportReactor": (2, 2)}

# Upgrade -> (stableid id, minerals, vespene, research loops, researched at, needs);
# costs and times of the 2021 dump, which match 4.10 after 2019-08-21 ("spawningtool").
UPGRADES = {
    "Stimpack": (15, 100, 100, 2240, "BarracksTechLab", None),
    "ShieldWall": (16, 100, 100, 1760, "BarracksTechLab", None),
    "PunisherGrenades": (17, 50, 50, 960, "BarracksTechLab", None),
    "TerranInfantryWeaponsLevel1": (7, 100, 100, 2560, "EngineeringBay", None),
    "TerranInfantryArmorsLevel1": (11, 100, 100, 2560, "EngineeringBay", None),
}

_API_FIELDS = {"unit_id": "sc2_id", "mineral_cost": "minerals", "vespene_cost": "vespene",
               "food_required": "food", "food_provided": "supply", "build_time": "build_time",
               "armor": "armor", "movement_speed": "speed", "sight_range": "sight",
               "cargo_size": "cargo_size", "ability_id": "ability_id"}


def read_dasc2(path: pathlib.Path) -> dict[str, dict]:
    """Name -> unit entry of daSC2's units.json, which is not strict JSON: repeated
    "attributes" and "weapons" keys (gathered into lists), unquoted attribute names,
    trailing commas."""
    text = path.read_text()
    text = re.sub(r'("attributes": )([A-Za-z]+)', r'\1"\2"', text)
    text = re.sub(r",(\s*[}\]])", r"\1", text)

    def gather(pairs):
        out = {}
        for key, value in pairs:
            if key in ("attributes", "weapons"):
                out.setdefault(key, []).append(value)
            else:
                out[key] = value
        return out

    return {unit["name"]: unit for unit in json.loads(text, object_pairs_hook=gather)
            if unit.get("name")}


def _weapon(entry: dict) -> dict:
    bonus = entry.get("damage_bonus") or {}
    return {"targets": entry["type"], "damage": entry["damage"],
            "bonus": bonus.get("bonus", 0.0), "bonus_attribute": bonus.get("attribute"),
            "attacks": entry["attacks"], "range": entry["range"], "cooldown": entry["speed"]}


def unit_row(name: str, api: dict, names: dict[int, str]) -> dict:
    """The table's row of one type, with the source of each field; `names` maps the
    dump's unit ids to names."""
    row, source = {}, {}
    for key, field in _API_FIELDS.items():
        row[field] = api.get(key, 0)
        source[field] = "api-4.1"
    row["attributes"] = api.get("attributes", [])
    row["weapons"] = [_weapon(w) for w in api.get("weapons", [])]
    source["attributes"] = source["weapons"] = "api-4.1"
    health, radius, max_energy, start_energy, cargo, flying = LATER_API[name]
    row.update(health=health, radius=radius, max_energy=max_energy,
               start_energy=start_energy, cargo_capacity=cargo, flying=flying)
    source.update(dict.fromkeys(
        ("health", "radius", "max_energy", "start_energy", "cargo_capacity", "flying"),
        "api-2021"))
    producers, requires, addon, morphs_from = TECH[name]
    row.update(producers=list(producers), requires=requires, requires_addon=addon,
               morphs_from=morphs_from)
    source.update(dict.fromkeys(("producers", "requires", "requires_addon", "morphs_from"),
                                "burnysc2"))
    # The type it counts as for requirements (a lowered depot is a depot); 0 for none.
    alias = api.get("tech_alias", 0)
    row["tech_alias"] = names[alias] if alias else None
    source["tech_alias"] = "api-4.1"
    row["footprint"] = list(FOOTPRINTS.get(name, (0, 0)))
    source["footprint"] = "footprint"
    row["source"] = source
    return row


def check_requirements(dasc2: dict[str, dict], names: dict[int, str]) -> None:
    """Raises unless every tech requirement the 4.1.1 dump gives is `TECH`'s; `names`
    maps the dump's unit ids to names."""
    for name, (_, requires, addon, _) in TECH.items():
        needed = dasc2[name].get("tech_requirement")
        if needed is None:
            continue
        ours = addon if dasc2[name].get("require_attached") else requires
        if names[needed] != ours:
            raise SystemExit(f"error: {name} needs {names[needed]} in the 4.1.1 dump, "
                             f"{ours} in TECH")


def table(dasc2: dict[str, dict]) -> dict:
    missing = sorted(set(TECH) - set(dasc2))
    if missing:
        raise SystemExit(f"error: not in the daSC2 units.json: {missing}")
    names = {unit["unit_id"]: name for name, unit in dasc2.items()}
    check_requirements(dasc2, names)
    units = {name: unit_row(name, dasc2[name], names) for name in TECH}
    upgrades = {
        name: {"upgrade_id": uid, "minerals": minerals, "vespene": vespene,
               "research_time": loops, "researched_at": at, "requires": needs,
               "source": {"upgrade_id": "api-2021", "minerals": "api-2021",
                          "vespene": "api-2021", "research_time":
                          "spawningtool" if name == "Stimpack" else "api-2021",
                          "researched_at": "burnysc2", "requires": "burnysc2"}}
        for name, (uid, minerals, vespene, loops, at, needs) in UPGRADES.items()}
    return {"sources": SOURCES, "units": units, "upgrades": upgrades}


def markdown(data: dict) -> str:
    """The table for docs/full_game.md: what making each type pays (a morph the difference
    from what it morphs from, as the API's costs are cumulative), times in seconds at
    Faster speed (22.4 loops)."""
    units = data["units"]
    faster = lambda loops: f"{loops / 22.4:.1f}"  # noqa: E731
    lines = ["| type | id | minerals | gas | supply | time (s) | health | armour | made by |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for name, row in units.items():
        source = units.get(row["morphs_from"], {"minerals": 0, "vespene": 0})
        maker = " or ".join(row["producers"]) or f"{row['morphs_from']} (morph)"
        needs = [x for x in (row["requires"], row["requires_addon"]) if x]
        maker += f", needs {' and '.join(needs)}" if needs else ""
        food = (f"{row['food']:g}" if row["food"] else
                f"+{row['supply']:g}" if row["supply"] else "")
        minerals, gas = row["minerals"] - source["minerals"], row["vespene"] - source["vespene"]
        if not row["ability_id"]:  # Called down for energy, whatever the API's cost says.
            minerals, gas, maker = "—", "—", f"{maker} (Calldown, 50 energy)"
        lines.append(f"| {name} | {row['sc2_id']} | {minerals} | {gas} | {food} | "
                     f"{faster(row['build_time'])} | {row['health']} | {row['armor']:g} | "
                     f"{maker} |")
    lines += ["", "| research | id | minerals | gas | time (s) | at |",
              "|---|---:|---:|---:|---:|---|"]
    for name, row in data["upgrades"].items():
        lines.append(f"| {name} | {row['upgrade_id']} | {row['minerals']} | {row['vespene']} "
                     f"| {faster(row['research_time'])} | {row['researched_at']} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dasc2_units", type=pathlib.Path,
                        help="daSC2 0.2.2.dev3's dasc2/data/units.json.")
    parser.add_argument("--markdown", action="store_true",
                        help="Print the packaged table as markdown; write nothing.")
    args = parser.parse_args()
    if args.markdown:
        print(markdown(terran_data.table()))
        return
    if args.dasc2_units is None:
        raise SystemExit("error: --dasc2_units is required (or --markdown)")
    if not args.dasc2_units.is_file():
        raise SystemExit(f"error: --dasc2_units {args.dasc2_units} is not a file")
    data = table(read_dasc2(args.dasc2_units))
    with atomic_write(OUTPUT) as f:
        f.write(json.dumps(data, indent=1, sort_keys=True) + "\n")
    print(f"wrote {OUTPUT}: {len(data['units'])} unit types, {len(data['upgrades'])} upgrades")


if __name__ == "__main__":
    main()
