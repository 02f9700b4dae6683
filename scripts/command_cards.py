"""Learns the command cards that replay datasets' `available_actions` use, from the
training split of a folder of replays (sc2jax.replay_sl.availability).

    python scripts/command_cards.py --replays=../shared/replays \
        --output=sc2jax/replay_sl/data/command_cards.json

It writes how often each function was used with only units of one type selected, in
the games of the training split; a function is on a type's card when it makes at least
`availability.MIN_SHARE` of the type's uses (the test split is never read, so the
held-out games measure the cards). Prints how many cards and functions it found.
"""

from __future__ import annotations

import argparse
import collections
import multiprocessing
import os
import time

from sc2jax.atomic import write_json_atomic
from sc2jax.replay_sl import ReplayError, label_players, open_replay, read_metadata, unit_table
from sc2jax.replay_sl.availability import cards_from_json, counts_to_json, learn_cards
from sc2jax.replay_sl.dataset import split_replays


def _one(path: str) -> collections.Counter | str:
    try:
        replay = open_replay(path)
        metadata = read_metadata(replay)
        labels = label_players(replay, metadata)
        table = unit_table(replay)
    except ReplayError as error:
        return error.reason
    counts = collections.Counter()
    for player_id, label in labels.items():
        learn_cards(counts, table, label, player_id)
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replays", required=True, help="a folder searched for .SC2Replay")
    parser.add_argument("--output", required=True, help="the JSON file to write")
    parser.add_argument("--processes", type=int, default=os.cpu_count())
    args = parser.parse_args()
    try:
        train = split_replays(args.replays, "train")
    except ValueError as error:
        raise SystemExit(str(error)) from None
    counts, failed, start = collections.Counter(), 0, time.time()
    with multiprocessing.get_context("spawn").Pool(args.processes) as pool:
        for i, result in enumerate(pool.imap_unordered(_one, train, chunksize=2), 1):
            if isinstance(result, str):
                failed += 1
            else:
                counts.update(result)
            if i % 50 == 0 or i == len(train):
                print(f"{i}/{len(train)} replays, {time.time() - start:.0f} s", flush=True)
    uses = counts_to_json(counts)
    write_json_atomic(args.output, uses)
    cards = cards_from_json(uses).table
    print(f"{len(train) - failed} training games ({failed} unreadable): "
          f"{len(uses)} unit types; {cards.sum()} card entries of "
          f"{sum(map(len, uses.values()))} type-function pairs used; "
          f"{time.time() - start:.0f} s")


if __name__ == "__main__":
    main()
