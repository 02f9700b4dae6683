"""The flags of the commands that write replay datasets (`convert_replays`,
`playback_replays`): the replays, the output folder and the dataset's `Settings`."""

from __future__ import annotations

import pathlib

from absl import flags

from sc2jax.replay_sl.dataset import Settings

REPLAYS = flags.DEFINE_string("replays", None, "A replay file, or a folder searched for "
                              ".SC2Replay files.")
OUTPUT = flags.DEFINE_string("output", None, "The dataset's folder.")
SCREEN = flags.DEFINE_integer("screen_size", 64, "Feature-screen resolution.")
MINIMAP = flags.DEFINE_integer("minimap_size", 64, "Feature-minimap resolution.")
STEP_MUL = flags.DEFINE_integer("step_mul", 8, "Game loops per agent step.")
FULL = flags.DEFINE_bool("full_information", False, "No fog of war: the enemy's units "
                         "outside the player's sight too, for ablations.")
MAX_STEPS = flags.DEFINE_integer("max_steps", 0, "Write at most this many agent steps per "
                                 "player (0: all), for a quick look.")


def settings_and_paths(command_cards: str | None = None) -> tuple[Settings, list[str]]:
    """The `Settings` from the flags, and the replay files of --replays, sorted.

    Raises:
      ValueError: for a missing --replays or --output, a bad setting, or no replays.
    """
    if not REPLAYS.value or not OUTPUT.value:
        raise ValueError("--replays and --output are required")
    settings = Settings(SCREEN.value, MINIMAP.value, STEP_MUL.value, FULL.value,
                        MAX_STEPS.value or None, command_cards)
    root = pathlib.Path(REPLAYS.value)
    paths = [str(root)] if root.is_file() else sorted(
        str(p) for p in root.rglob("*.SC2Replay"))
    if not paths:
        raise ValueError(f"no .SC2Replay files at {REPLAYS.value!r}")
    return settings, paths
