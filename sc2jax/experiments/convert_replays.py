r"""Converts a folder of replays into a dataset of PySC2-labelled agent steps.

    python -m sc2jax.experiments.convert_replays --replays=../shared/replays \
        --output=/data/sc2_replays_64

Each replay becomes one ArrayRecord shard under OUTPUT/train or OUTPUT/test (one game in
ten, by its SHA-1), holding every agent step of both players: feature layers, the player
vector, `available_actions`, the action as a `DenseAction` and the value target
(`sc2jax.replay_sl.dataset`).
Replays are converted in parallel over --processes; running the command again resumes,
skipping the shards already written. A replay that cannot be read is skipped, and its
reason is logged and kept in OUTPUT/conversion.json.
"""

from __future__ import annotations

import os
import pathlib
import sys
import time

from absl import app, flags

from sc2jax.replay_sl.availability import load_cards
from sc2jax.replay_sl.dataset import Settings, convert_replays, summary_line

_REPLAYS = flags.DEFINE_string("replays", None, "A folder searched for .SC2Replay files.")
_OUTPUT = flags.DEFINE_string("output", None, "The dataset's folder.")
_SCREEN = flags.DEFINE_integer("screen_size", 64, "Feature-screen resolution.")
_MINIMAP = flags.DEFINE_integer("minimap_size", 64, "Feature-minimap resolution.")
_STEP_MUL = flags.DEFINE_integer("step_mul", 8, "Game loops per agent step.")
_FULL = flags.DEFINE_bool("full_information", False, "Draw the enemy's units outside the "
                          "player's sight too (no fog of war), for ablations.")
_PROCESSES = flags.DEFINE_integer("processes", os.cpu_count() or 1, "Replays converted at "
                                  "once.")
_CARDS = flags.DEFINE_string("command_cards", None, "A JSON file of command-card uses "
                             "(scripts/command_cards.py) deciding available_actions; "
                             "default: the ones sc2jax ships.")
_MAX_STEPS = flags.DEFINE_integer("max_steps", 0, "Convert at most this many agent steps "
                                  "per player (0: all), for a quick look.")


def main(argv) -> None:
    del argv
    if not _REPLAYS.value or not _OUTPUT.value:
        sys.exit("error: --replays and --output are required")
    try:
        settings = Settings(_SCREEN.value, _MINIMAP.value, _STEP_MUL.value, _FULL.value,
                            _MAX_STEPS.value or None, _CARDS.value)
        if settings.command_cards is not None:
            load_cards(settings.command_cards)
    except (ValueError, OSError) as error:
        sys.exit(f"error: {error}")
    paths = sorted(str(p) for p in pathlib.Path(_REPLAYS.value).rglob("*.SC2Replay"))
    if not paths:
        sys.exit(f"error: no .SC2Replay files under {_REPLAYS.value!r}")
    start = time.time()
    try:
        summary = convert_replays(paths, _OUTPUT.value, settings, processes=_PROCESSES.value)
    except ValueError as error:
        sys.exit(f"error: {error}")
    print("\n" + summary_line(summary, _OUTPUT.value, time.time() - start))


if __name__ == "__main__":
    app.run(main)
