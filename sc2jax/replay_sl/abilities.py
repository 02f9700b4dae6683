"""A replay's commands -> PySC2's functions, through the build's ability names.

A command in a replay names its ability by the build's ability link and a command index.
The link's name comes from sc2reader's table for the build (the nearest lower build it
has a table for). Blizzard's `stableid.json` maps (name, command index) to the stable
ability id that PySC2's function table uses (a few names through `ALIASES`). From that
id, `functions.function_for_ability` finds the PySC2 function as PySC2's `reverse_action`
does: the general ability where the specific one has one (`Attack_Attack_screen` ->
`Attack_screen`), then the function of the command's kind (`_screen`, `_minimap`,
`_quick` or `_autocast`).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
import importlib.util
import json
import os
import re

from sc2jax.environment.interface.functions import FunctionType, function_for_ability

_TABLE_NAME = re.compile(r"^(\d+|base)_abilities\.csv$")


@functools.cache
def stable_ability_ids() -> dict[tuple[str, int], tuple[int, int]]:
    """(ability name, command index) -> (stable id, remap id or 0), from stableid.json."""
    data = importlib.resources.files("sc2jax.replay_sl") / "data" / "stableid.json"
    abilities = json.loads(data.read_text(encoding="utf-8"))["Abilities"]
    return {(a["name"], a["index"]): (a["id"], a.get("remapid", 0))
            for a in abilities if a.get("name")}


def _sc2reader_tables() -> str:
    spec = importlib.util.find_spec("sc2reader")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("sc2reader is not installed; it holds the builds' ability tables "
                          "(pip install sc2reader)")
    return os.path.join(spec.submodule_search_locations[0], "data", "LotV")


ALIASES = {
    # sc2reader's 70154 table names link 155 so; its 76114 table, the same link
    # CommandCenterTrain, stableid's name.
    "OrbitalCommandTrain": "CommandCenterTrain",
    # sc2reader's tables list these with the same commands (a tech lab, a reactor) as the
    # names stableid knows.
    "FactoryBuild": "FactoryAddOns",
    "StarportBuild": "StarportAddOns",
    # A creep tumor's own spread (stableid's "Build CreepTumor Tumor").
    "CreepTumorBurrowedBuild": "CreepTumorBuild",
    # Spelling.
    "TemplarArchiveResearch": "TemplarArchivesResearch",
    # The queen, trained at a hatchery, lair or hive (sc2reader's tables name link 243
    # or 245 after one of the three; index 0 is the queen in each).
    "HatcheryTrain": "TrainQueen",
    "LairTrain": "TrainQueen",
    "HiveTrain": "TrainQueen",
    # A zergling's morph to a baneling.
    "ZerglingTrain": "MorphZerglingToBaneling",
}
"""sc2reader's ability names that stableid.json knows under another name."""


@functools.cache
def ability_table_build(base_build: int) -> str:
    """sc2reader's ability table for a base build: the nearest lower build's, or "base"."""
    builds = sorted(int(m.group(1)) for m in map(_TABLE_NAME.match,
                                                 os.listdir(_sc2reader_tables()))
                    if m and m.group(1) != "base")
    lower = [b for b in builds if b <= base_build]
    return str(lower[-1]) if lower else "base"


@functools.cache
def ability_names(base_build: int) -> dict[int, str]:
    """Ability link -> the build's ability name (sc2reader's table)."""
    names = {}
    path = os.path.join(_sc2reader_tables(), f"{ability_table_build(base_build)}_abilities.csv")
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.strip():
                link, name = line.strip().split(",")
                names[int(link)] = name
    return names


@functools.cache
def _stable_name(name: str) -> str:
    """The name stableid.json uses for a build's ability name: itself, its alias, or the
    same name in other letter case."""
    name = ALIASES.get(name, name)
    known = {n for n, _ in stable_ability_ids()}
    if name in known:
        return name
    return {n.lower(): n for n in known}.get(name.lower(), name)


@dataclasses.dataclass(frozen=True)
class Resolved:
    """What a command's ability resolves to.

    Attributes:
      name: the build's ability name and command index, e.g. "BarracksTrain/0".
      ability_id: the stable ability id (0 where the name has none).
      function: PySC2's function id, or None where PySC2 has no function for it.
    """

    name: str
    ability_id: int
    function: int | None


def resolve(base_build: int, link: int, cmd_index: int, kind: FunctionType) -> Resolved:
    """The PySC2 function of a command: ability `link`/`cmd_index` of `base_build`, issued
    as `kind` (cmd_screen, cmd_minimap, cmd_quick or autocast)."""
    name = ability_names(base_build).get(link)
    if name is None:
        return Resolved(f"link {link}/{cmd_index}", 0, None)
    ability_id, remap = stable_ability_ids().get((_stable_name(name), cmd_index), (0, 0))
    return Resolved(f"{name}/{cmd_index}", ability_id,
                    function_for_ability(ability_id, kind) or function_for_ability(remap, kind))
