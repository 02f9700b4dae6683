"""sc2jax.replay_sl: supervised learning from human replays, without the game (paper §5).

Replays are decoded with Blizzard's s2protocol (`archive`), their players told apart
from the observers (`metadata`), and each player's actions labelled with PySC2 function
calls, one per agent step (`actions`, through `abilities`). `units` gathers the
tracker events into a table of every unit, which the feature layers (`observations`)
and `available_actions` (`availability`) are drawn from. `dataset` writes them as
ArrayRecord shards and loads minibatches; `learner` trains a dual-headed network on them.
"""

from sc2jax.replay_sl.actions import ActionLabels, Coverage, Step, label_actions, label_players
from sc2jax.replay_sl.archive import Replay, ReplayError, open_replay
from sc2jax.replay_sl.metadata import Player, ReplayMetadata, read_metadata
from sc2jax.replay_sl.units import UnitTable, unit_table

__all__ = [name for name in dir() if not name.startswith("_")]
