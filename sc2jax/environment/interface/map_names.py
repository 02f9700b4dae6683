"""The simulator's maps: the seven mini-games (PySC2's `mini_games`, in the paper's
order) and the ladder maps it plays melee games on (PySC2's `ladder` names)."""

from __future__ import annotations

from sc2jax.environment.interface.suggest import did_you_mean

MINI_GAMES = ("MoveToBeacon", "CollectMineralShards", "FindAndDefeatZerglings", "DefeatRoaches",
              "DefeatZerglingsAndBanelings", "CollectMineralsAndGas", "BuildMarines")

LADDER_MAPS = ("Acropolis", "CyberForest", "DiscoBloodbath", "Ephemeron", "KairosJunction",
               "KingsCove", "NewRepugnancy", "Thunderbird", "Triton", "WintersGate",
               "WorldofSleepers")
"""The ladder maps whose layouts the simulator has (`engine.ladder`), for melee games."""
SIMULATOR_MAPS = MINI_GAMES + LADDER_MAPS


def check_map(name, note: str = "") -> None:
    """Raises ValueError, listing the simulator's maps (then `note`), unless `name` is
    one."""
    if not isinstance(name, str) or name not in SIMULATOR_MAPS:
        raise ValueError(f"unknown map {name!r}; the simulator has the mini-games "
                         f"{sorted(MINI_GAMES)} and the ladder maps {sorted(LADDER_MAPS)}"
                         f"{note}{did_you_mean(name, SIMULATOR_MAPS)}")
