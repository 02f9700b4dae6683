"""The mini-games the simulator runs, by name."""

from sc2jax.environment.minigames.base import MiniGame
from sc2jax.environment.minigames.collect_mineral_shards import CollectMineralShards
from sc2jax.environment.minigames.economy import BuildMarines, CollectMineralsAndGas
from sc2jax.environment.minigames.find_and_defeat_zerglings import FindAndDefeatZerglings
from sc2jax.environment.minigames.move_to_beacon import MoveToBeacon
from sc2jax.environment.minigames.wave_combat import DefeatRoaches, DefeatZerglingsAndBanelings

MAPS = {
    "MoveToBeacon": MoveToBeacon,
    "CollectMineralShards": CollectMineralShards,
    "FindAndDefeatZerglings": FindAndDefeatZerglings,
    "DefeatRoaches": DefeatRoaches,
    "DefeatZerglingsAndBanelings": DefeatZerglingsAndBanelings,
    "CollectMineralsAndGas": CollectMineralsAndGas,
    "BuildMarines": BuildMarines,
}


def check_map(name, note: str = "") -> None:
    """Raises ValueError, listing the known maps (then `note`), unless the simulator has
    a map called `name`."""
    if not isinstance(name, str) or name not in MAPS:
        raise ValueError(f"unknown map {name!r}; the simulator has {sorted(MAPS)}{note}")


def get_map(name: str) -> MiniGame:
    """Returns the mini-game called `name`.

    Raises:
      ValueError: for an unknown name, listing the known ones.
    """
    check_map(name)
    return MAPS[name]()
