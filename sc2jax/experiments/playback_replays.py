r"""Plays replays back in StarCraft II and writes what the game shows as a dataset.

    python -m sc2jax.experiments.playback_replays --replays=REPLAYS --output=DIR \
        --sc2path=~/StarCraftII

With the game installed, each replay is watched for each of its players, as PySC2's
`replay_actions` does: every --step_mul game loops the game's own feature layers,
`player` vector and `available_actions`, labelled with the player's next action as a
PySC2 call, and the player's result as the value (`sc2jax.replay_sl.playback`). The
dataset has the format `convert_replays` writes without the game, so `train_replays`
reads both. A replay plays in the game of its own build (`Versions/Base<build>`), which
must be installed; a replay that cannot be played is skipped with the reason in
OUTPUT/conversion.json. Running the command again resumes.

sc2jax's SC2-API server (`python -m sc2jax.environment.server`, or an install layout
from `install_layout.write_sc2path`) plays back the simulator's own replays (saved by
`GameEnv(save_replay_episodes=...)`), not the game's.
"""

from __future__ import annotations

import sys
import time

from absl import app, flags

from sc2jax.environment.sc2api.launcher import GameProcess, launch
from sc2jax.experiments.replay_training import dataset_flags
from sc2jax.replay_sl.archive import ReplayError, base_build
from sc2jax.replay_sl.dataset import Settings, convert_replays, summary_line
from sc2jax.replay_sl.playback import replay_file_records

_SC2PATH = flags.DEFINE_string("sc2path", None, "The game's install (default $SC2PATH or "
                               "the platform's usual place).")
flags.adopt_module_key_flags(dataset_flags)


def _build_or_zero(path: str) -> tuple[int, str]:
    """Replays ordered by build, so each game is launched once."""
    try:
        return base_build(path), path
    except ReplayError:
        return 0, path


class _Games:
    """The game of each replay's build, launched when a replay of another build comes."""

    def __init__(self, sc2path: str | None):
        self.sc2path, self.build, self.game = sc2path, None, None

    def records(self, path, settings: Settings):
        try:
            build = base_build(path)
        except ReplayError:
            build = None  # Not the game's archive (a simulator replay): the newest game.
        if self.game is None or build != self.build or not self.game.running():
            self.close()
            try:
                self.game = launch(self.sc2path, build)
            except (FileNotFoundError, ValueError, ConnectionError) as error:
                raise ReplayError(path, f"no game to play it back: {error}") from None
            self.build = build
        yield from replay_file_records(path, settings, self.game.controller)

    def close(self) -> None:
        if isinstance(self.game, GameProcess):
            self.game.close()
        self.game = None


def main(argv) -> None:
    del argv
    try:
        settings, paths = dataset_flags.settings_and_paths()
    except ValueError as error:
        sys.exit(f"error: {error}")
    games, start = _Games(_SC2PATH.value), time.time()
    try:
        summary = convert_replays(sorted(paths, key=_build_or_zero), dataset_flags.OUTPUT.value,
                                  settings, records=games.records)
    except ValueError as error:
        sys.exit(f"error: {error}")
    finally:
        games.close()
    print("\n" + summary_line(summary, dataset_flags.OUTPUT.value, time.time() - start))


if __name__ == "__main__":
    app.run(main)
