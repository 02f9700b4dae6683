"""A human replay in the viewer, decoded without the game (`sc2jax.replay_sl`).

`ReplayPlayback(path, player_id)` decodes a replay once (its players, one player's
labelled actions, the unit table) and draws any agent step on demand, as the replay
dataset sees it (`observations.observe_step`): the player's feature layers at 64², with
fog of war unless `full_information`. The page's main picture is the whole map at the
view's width, minimap-level (units from the unit table at their estimated points,
coloured by their owner relative to the player; cells the player cannot see dimmed; the
camera's rectangle in white); beside it the 38 feature layers and the player's PySC2
call at that step. It is a `Timeline` for `ViewerServer`: `seek`, `step`, `frame`.
"""

from __future__ import annotations

import os

import numpy as np

from sc2jax.environment.interface.dense import to_dense
from sc2jax.environment.interface.features import (
    MINIMAP_FEATURES,
    SCREEN_FEATURES,
    Visibility,
)
from sc2jax.environment.interface.palettes import colorize
from sc2jax.experiments.viewer.frames import action_text
from sc2jax.experiments.viewer.session import Frame, Timeline, available_functions
from sc2jax.replay_sl import label_players, open_replay, read_metadata, unit_table
from sc2jax.replay_sl.availability import load_cards
from sc2jax.replay_sl.observations import View, observe_step

_HIDDEN_GROUND, _SEEN_GROUND = np.float32([22, 22, 28]), np.float32([58, 54, 46])


class ReplayPlayback(Timeline):
    """One player's view of a decoded replay, step by step.

    Args:
      path: the .SC2Replay file.
      player_id: whose view (1-based; see `replay_info`).
      width: the main picture's width in pixels.
      full_information: draw every enemy unit, not only those the player sees.

    Raises:
      ReplayError: for a replay that cannot be read.
      ValueError: for a player that is not one of the replay's.
    """

    def __init__(self, path: str | os.PathLike, player_id: int = 1, width: int = 384,
                 full_information: bool = False):
        super().__init__()
        replay = open_replay(path)
        self.metadata = read_metadata(replay)
        ids = [p.player_id for p in self.metadata.players]
        if player_id not in ids:
            raise ValueError(f"player {player_id!r} is not one of the replay's players {ids}")
        self.player = self.metadata.player(player_id)
        self.labels = label_players(replay, self.metadata, [player_id])[player_id]
        self.table = unit_table(replay)
        description = replay.initdata["m_syncLobbyState"]["m_gameDescription"]
        map_size = (int(description["m_mapSizeX"]), int(description["m_mapSizeY"]))
        self._layers_view = View(map_size, 64, 64, full_information)
        self._map_view = View(map_size, 16, min(256, max(64, width // 2)), full_information)
        self._width = width
        self._cards = load_cards()
        opponents = [p for p in self.metadata.players if p.player_id != player_id]
        self._summary = (f"{self.player.name} ({self.player.race}, {self.player.result}) "
                         f"against " + ", ".join(f"{p.name} ({p.race})" for p in opponents))

    @property
    def length(self) -> int:
        """The player's agent steps."""
        return len(self.labels.steps)

    def _draw(self, t: int) -> Frame:
        pid = self.player.player_id
        obs = observe_step(self.table, self.labels, t, pid, self._layers_view, self._cards)
        big = observe_step(self.table, self.labels, t, pid, self._map_view, self._cards)
        panels, values = {}, {}
        for key, features in (("feature_screen", SCREEN_FEATURES),
                              ("feature_minimap", MINIMAP_FEATURES)):
            for feature in features:
                values[feature] = np.asarray(obs[key][feature.index], np.int32)
                panels[feature] = np.asarray(colorize(values[feature], feature))
        step = self.labels.steps[t]
        status = {"version": t, "map": self.metadata.map_name, "mode": "replay",
                  "agent": f"player {pid}", "step": t, "length": self.length,
                  "game_loop": int(step.game_loop), "score": self._summary,
                  "last_call": action_text(to_dense(step.call)),
                  "available": available_functions(obs["available_actions_mask"]),
                  "screen_size": [64, 64], "minimap_size": [64, 64]}
        return Frame(self._map_picture(big["feature_minimap"]),
                     panels[MINIMAP_FEATURES.player_relative], panels, values, status)

    def _map_picture(self, minimap: np.ndarray) -> np.ndarray:
        """uint8[W, W, 3]: the whole map from a large minimap's layers (int32[11, M, M])."""
        relative = minimap[MINIMAP_FEATURES.player_relative.index]
        seen = minimap[MINIMAP_FEATURES.visibility_map.index] == Visibility.VISIBLE
        image = np.where(seen[..., None], _SEEN_GROUND, _HIDDEN_GROUND)
        units = np.asarray(colorize(relative, MINIMAP_FEATURES.player_relative), np.float32)
        image = np.where((relative > 0)[..., None], units, image)
        camera = minimap[MINIMAP_FEATURES.camera.index] > 0
        inner = camera.copy()
        inner[1:-1, 1:-1] = camera[:-2, 1:-1] & camera[2:, 1:-1] & camera[1:-1, :-2] \
            & camera[1:-1, 2:] & camera[1:-1, 1:-1]
        image = np.where((camera & ~inner)[..., None], np.float32([255, 255, 255]), image)
        scale = max(1, self._width // image.shape[1])
        return np.repeat(np.repeat(image, scale, 0), scale, 1).astype(np.uint8)
