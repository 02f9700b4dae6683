"""How well the replay labeller tracks each player's selection, on the held-out games.

    python scripts/selection_tracking.py --replays=../shared/replays

A replay never says what is selected: the labeller rebuilds it from selection deltas
(units added by tag, removed by index) and control groups (sc2jax.replay_sl.actions).
Two measures, over the games of the test split:

- **Commands on a selected type's card:** of the labelled commands whose function is
  decided by the command cards, the share on the card (the shipped
  `command_cards.json`, learned from the training split) of at least one selected unit
  type of the player. A wrong selection puts commands on types that have no such button.
- **Removal masks:** the game trims a remove mask after its last removed unit, so the
  mask's last index is almost always a removed unit. Of the masks longer than 8 whose
  length is not a multiple of 8 (where the readings differ), the share whose last index
  is set under the labeller's reading (`actions.removed_indices`) and under the plain
  one (bit i of s2protocol's integer as index i).
"""

from __future__ import annotations

import argparse
import collections
import multiprocessing
import os
import time

import numpy as np

from sc2jax.replay_sl import ReplayError, label_players, open_replay, read_metadata, unit_table
from sc2jax.replay_sl.actions import removed_indices
from sc2jax.replay_sl.availability import FIRST_CARD_FUNCTION, load_cards
from sc2jax.replay_sl.dataset import split_replays


def _one(path: str) -> collections.Counter | str:
    try:
        replay = open_replay(path)
        metadata = read_metadata(replay)
        labels = label_players(replay, metadata)
        table = unit_table(replay)
    except ReplayError as error:
        return error.reason
    cards, out = load_cards().table, collections.Counter()
    for player_id, label in labels.items():
        steps = [t for t, s in enumerate(label.steps) if s.call.function >= FIRST_CARD_FUNCTION]
        at = table.at([label.steps[t].game_loop for t in steps])
        for n, t in enumerate(steps):
            rows = np.isin(table.tag, np.asarray(label.selections[t], np.int64))
            types = at.unit_type[n][rows & at.alive[n] & (at.owner[n] == player_id)]
            out["commands"] += 1
            out["on_card"] += bool(cards[types, label.steps[t].call.function].any())
    user_ids = {p.user_id for p in metadata.players}
    for e in replay.game_events():
        if (e["_event"] != "NNet.Game.SSelectionDeltaEvent"
                or e["_userid"]["m_userId"] not in user_ids):
            continue
        kind, value = next(iter(e["m_delta"]["m_removeMask"].items()))
        length, bits = value if kind == "Mask" else (0, 0)
        if length > 8 and length % 8:
            out["masks"] += 1
            out["last_set"] += (length - 1) in removed_indices(length, bits)
            out["last_set_plain"] += (bits >> (length - 1)) & 1
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replays", required=True, help="a folder searched for .SC2Replay")
    parser.add_argument("--processes", type=int, default=os.cpu_count())
    args = parser.parse_args()
    try:
        test = split_replays(args.replays, "test")
    except ValueError as error:
        raise SystemExit(str(error)) from None
    total, failed, start = collections.Counter(), 0, time.time()
    with multiprocessing.get_context("spawn").Pool(args.processes) as pool:
        for result in pool.imap_unordered(_one, test, chunksize=1):
            if isinstance(result, str):
                failed += 1
            else:
                total.update(result)
    print(f"{len(test) - failed} held-out games ({failed} unreadable), "
          f"{time.time() - start:.0f} s")
    print(f"commands on a selected type's card: {total['on_card']:,} of "
          f"{total['commands']:,} ({total['on_card'] / max(total['commands'], 1):.2%})")
    print(f"removal masks whose last index is set, of {total['masks']:,}: "
          f"{total['last_set'] / max(total['masks'], 1):.1%} as read, "
          f"{total['last_set_plain'] / max(total['masks'], 1):.1%} with bit i as index i")


if __name__ == "__main__":
    main()
