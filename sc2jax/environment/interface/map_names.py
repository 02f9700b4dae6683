"""The names of the seven mini-games (PySC2's `mini_games`), in the paper's order."""

from __future__ import annotations

from sc2jax.environment.interface.suggest import did_you_mean

MINI_GAMES = ("MoveToBeacon", "CollectMineralShards", "FindAndDefeatZerglings", "DefeatRoaches",
              "DefeatZerglingsAndBanelings", "CollectMineralsAndGas", "BuildMarines")


def check_map(name, note: str = "") -> None:
    """Raises ValueError, listing the mini-games (then `note`), unless `name` is one."""
    if not isinstance(name, str) or name not in MINI_GAMES:
        raise ValueError(f"unknown map {name!r}; the simulator has {sorted(MINI_GAMES)}{note}"
                         f"{did_you_mean(name, MINI_GAMES)}")
