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
import sys
import time

from absl import app, flags

from sc2jax.experiments.replay_training import dataset_flags
from sc2jax.replay_sl.availability import load_cards
from sc2jax.replay_sl.dataset import convert_replays, summary_line

_PROCESSES = flags.DEFINE_integer("processes", os.cpu_count() or 1, "Replays converted at "
                                  "once.")
_CARDS = flags.DEFINE_string("command_cards", None, "A JSON file of command-card uses "
                             "(scripts/command_cards.py) deciding available_actions; "
                             "default: the ones sc2jax ships.")
flags.adopt_module_key_flags(dataset_flags)


def main(argv) -> None:
    del argv
    try:
        settings, paths = dataset_flags.settings_and_paths(_CARDS.value)
        if settings.command_cards is not None:
            load_cards(settings.command_cards)
    except (ValueError, OSError) as error:
        sys.exit(f"error: {error}")
    start = time.time()
    try:
        summary = convert_replays(paths, dataset_flags.OUTPUT.value, settings,
                                  processes=_PROCESSES.value)
    except ValueError as error:
        sys.exit(f"error: {error}")
    print("\n" + summary_line(summary, dataset_flags.OUTPUT.value, time.time() - start))


if __name__ == "__main__":
    app.run(main)
