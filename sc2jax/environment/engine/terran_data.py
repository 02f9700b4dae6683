"""The Terran data table: costs, times, requirements and stats from the game's data.

`scripts/terran_data.py` writes `data/terran.json` from public dumps of the game API's
unit and upgrade data; every value carries its source (docs/fidelity.md). Times are in
game loops, speeds in world units per game second and cooldowns in game seconds, both
at Normal speed, as the API gives them.
"""

from __future__ import annotations

import functools
import importlib.resources
import json

DATA = "data/terran.json"


@functools.cache
def table() -> dict:
    """{"sources": {key: text}, "units": {name: row}, "upgrades": {name: row}}; each row's
    "source" maps its fields to `sources` keys."""
    path = importlib.resources.files(__package__).joinpath(DATA)
    return json.loads(path.read_text())


def unit(name: str) -> dict:
    """One unit type's row, by its game name ("Marauder")."""
    units = table()["units"]
    if name not in units:
        raise KeyError(f"{name!r} is not in the Terran data table; it has {sorted(units)}")
    return units[name]
