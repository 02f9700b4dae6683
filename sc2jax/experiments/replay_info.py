r"""Prints a replay's metadata, and a player's actions as PySC2 function calls.

    python -m sc2jax.experiments.replay_info GAME.SC2Replay
    python -m sc2jax.experiments.replay_info GAME.SC2Replay --actions --player=1
    python -m sc2jax.experiments.replay_info GAME.SC2Replay --actions --player=2 \
        --output=actions.json

Reads the replay without the game (`sc2jax.replay_sl`). With --actions it prints the
player's PySC2 function call for each agent step of --step_mul game loops (no_op where
the player did nothing that maps), then how the player's game events mapped. --output
writes {"metadata": {...}, "steps": [{"game_loop", "function", "name", "arguments"}]}
as JSON, no_op steps included.
"""

from __future__ import annotations

import sys

from absl import app, flags

from sc2jax.atomic import write_json_atomic
from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.replay_sl import ReplayError, label_actions, open_replay, read_metadata

_ACTIONS = flags.DEFINE_bool("actions", False, "Print the player's function calls.")
_PLAYER = flags.DEFINE_integer("player", 1, "The player whose actions to label (1 or 2).")
_STEP_MUL = flags.DEFINE_integer("step_mul", 8, "Game loops per agent step.")
_SCREEN = flags.DEFINE_integer("screen_size", 64, "Screen resolution of the points.")
_MINIMAP = flags.DEFINE_integer("minimap_size", 64, "Minimap resolution of the points.")
_OUTPUT = flags.DEFINE_string("output", None, "Write the metadata and the steps as JSON.")


def main(argv) -> None:
    if len(argv) != 2:
        sys.exit("usage: python -m sc2jax.experiments.replay_info FILE.SC2Replay [--actions "
                 "--player=ID] [--output=FILE.json]")
    try:
        replay = open_replay(argv[1])
        metadata = read_metadata(replay)
    except (FileNotFoundError, ReplayError) as error:
        sys.exit(f"error: {error}")
    print(f"{argv[1]}\n  map {metadata.map_name}, version {metadata.version} (base build "
          f"{metadata.base_build}, decoded with protocol {replay.protocol_build}), "
          f"{metadata.game_loops} game loops ({metadata.game_loops / 22.4 / 60:.1f} min)")
    for p in metadata.players:
        print(f"  player {p.player_id}: {p.name} ({p.race}), {p.result}")
    print(f"  observers and others in the lobby (user ids): {list(metadata.observer_user_ids)}")
    if not (_ACTIONS.value or _OUTPUT.value):
        return
    try:
        labels = label_actions(replay, metadata, _PLAYER.value, screen_size=_SCREEN.value,
                               minimap_size=_MINIMAP.value, step_mul=_STEP_MUL.value)
    except (ValueError, ReplayError) as error:
        sys.exit(f"error: {error}")
    steps = [{"game_loop": s.game_loop, "function": int(s.call.function),
              "name": FUNCTIONS[s.call.function].name,
              "arguments": [[int(v) for v in a] for a in s.call.arguments]}
             for s in labels.steps]
    if _ACTIONS.value:
        for s in steps:
            print(f"{s['game_loop']:>7}  {s['function']:>3} {s['name']}{s['arguments']}")
        c = labels.coverage
        total, mapped = sum(c.events.values()), sum(c.mapped.values())
        print(f"\nPlayer {_PLAYER.value}: {len(steps)} agent steps, {c.labelled} with an "
              f"action; {mapped} of {total} game events map to a function")
        for kind, n in c.events.most_common():
            print(f"  {kind:<32} {c.mapped[kind]:>6} of {n:>6}")
        for reason, n in c.unmapped.most_common():
            print(f"  not mapped: {reason} ({n})")
    if _OUTPUT.value:
        write_json_atomic(_OUTPUT.value, {"metadata": metadata.to_json(), "steps": steps})
        print(f"Wrote {_OUTPUT.value}")


if __name__ == "__main__":
    app.run(main)
