"""The simulator's maps: the seven mini-games (PySC2's `mini_games`, in the paper's
order) and the ladder maps it plays melee games on (PySC2's `ladder` names)."""

from __future__ import annotations

import pathlib
import re

from sc2jax.environment.interface.suggest import did_you_mean

MINI_GAMES = ("MoveToBeacon", "CollectMineralShards", "FindAndDefeatZerglings", "DefeatRoaches",
              "DefeatZerglingsAndBanelings", "CollectMineralsAndGas", "BuildMarines")

LADDER_MAPS = ("Acropolis", "CyberForest", "DiscoBloodbath", "Ephemeron", "KairosJunction",
               "KingsCove", "NewRepugnancy", "Thunderbird", "Triton", "WintersGate",
               "WorldofSleepers")
"""The ladder maps whose layouts the simulator has (`engine.ladder`), for melee games."""
SIMULATOR_MAPS = MINI_GAMES + LADDER_MAPS
_SEASON_2 = ("CyberForest", "KairosJunction", "KingsCove", "NewRepugnancy")
LADDER_MAP_PATHS = {name: f"Ladder2019Season{2 if name in _SEASON_2 else 3}/{name}LE.SC2Map"
                    for name in LADDER_MAPS}
"""Each ladder map's file under the game's Maps folder, as PySC2's `maps.ladder` has it."""


def map_of_path(path: str) -> str | None:
    """The simulator's map a game's map path or Battle.net name stands for (by its file
    name: "mini_games/MoveToBeacon.SC2Map", "Ladder2019Season3/AcropolisLE.SC2Map",
    "Acropolis LE"), or None.

    Ladder names lose spaces, apostrophes, dashes and the "LE" ending, as PySC2's do.
    """
    stem = pathlib.PurePath(path.replace("\\", "/")).name
    stem = stem[:-len(".SC2Map")] if stem.endswith(".SC2Map") else stem
    if stem in MINI_GAMES:
        return stem
    name = re.sub(r"[ '-]|[LTRS]E$", "", stem)
    return name if name in LADDER_MAPS else None


def check_map(name, note: str = "") -> None:
    """Raises ValueError, listing the simulator's maps (then `note`), unless `name` is
    one."""
    if not isinstance(name, str) or name not in SIMULATOR_MAPS:
        raise ValueError(f"unknown map {name!r}; the simulator has the mini-games "
                         f"{sorted(MINI_GAMES)} and the ladder maps {sorted(LADDER_MAPS)}"
                         f"{note}{did_you_mean(name, SIMULATOR_MAPS)}")
