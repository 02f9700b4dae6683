"""The maps the simulator runs, by name: the seven mini-games and the melee maps."""

from sc2jax.environment.engine.minigames.base import MiniGame
from sc2jax.environment.engine.minigames.collect_mineral_shards import CollectMineralShards
from sc2jax.environment.engine.minigames.economy import BuildMarines, CollectMineralsAndGas
from sc2jax.environment.engine.minigames.find_and_defeat_zerglings import FindAndDefeatZerglings
from sc2jax.environment.engine.minigames.melee import Melee
from sc2jax.environment.engine.minigames.move_to_beacon import MoveToBeacon
from sc2jax.environment.engine.minigames.wave_combat import (
    DefeatRoaches,
    DefeatZerglingsAndBanelings,
)
from sc2jax.environment.interface.map_names import MINI_GAMES, check_map

MAPS = {
    "MoveToBeacon": MoveToBeacon,
    "CollectMineralShards": CollectMineralShards,
    "FindAndDefeatZerglings": FindAndDefeatZerglings,
    "DefeatRoaches": DefeatRoaches,
    "DefeatZerglingsAndBanelings": DefeatZerglingsAndBanelings,
    "CollectMineralsAndGas": CollectMineralsAndGas,
    "BuildMarines": BuildMarines,
}
assert tuple(MAPS) == MINI_GAMES


def get_map(name: str) -> MiniGame:
    """Returns the map called `name`: a mini-game, or a ladder map's melee game.

    Raises:
      ValueError: for an unknown name, listing the known ones.
    """
    check_map(name)
    return MAPS[name]() if name in MAPS else Melee.on(name)
