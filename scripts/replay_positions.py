"""How far the estimates of units' points are from the tracker's reports (docs/replays.md).

    python scripts/replay_positions.py --replays=../shared/replays --every=5

For every `--every`-th replay, labels both players (their orders), builds the unit table,
and measures `sc2jax.replay_sl.positions.errors` for each method; prints the median,
mean and 90th percentile over all reports, in world units.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import pathlib
import time

import numpy as np

from sc2jax.replay_sl import ReplayError, label_players, open_replay, read_metadata
from sc2jax.replay_sl.positions import METHODS, errors
from sc2jax.replay_sl.units import unit_table


def _one(path: str):
    try:
        replay = open_replay(path)
        labels = label_players(replay, read_metadata(replay))
    except ReplayError as error:
        return None, error.reason
    orders = [o for label in labels.values() for o in label.orders]
    return errors(unit_table(replay), orders), None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replays", required=True)
    parser.add_argument("--every", type=int, default=1, help="measure every N-th replay")
    parser.add_argument("--processes", type=int, default=os.cpu_count())
    args = parser.parse_args()
    paths = sorted(str(p) for p in pathlib.Path(args.replays).rglob("*.SC2Replay"))
    paths = paths[::args.every]
    start, found, failed = time.time(), {m: [] for m in METHODS}, 0
    with multiprocessing.Pool(args.processes) as pool:
        for result, error in pool.imap_unordered(_one, paths, chunksize=2):
            if error:
                failed += 1
                continue
            for m in METHODS:
                found[m].append(result[m])
    print(f"{len(paths)} replays ({failed} unreadable), {time.time() - start:.0f} s\n")
    print("| estimate | reports | median | mean | 90th percentile |\n|---|---:|---:|---:|---:|")
    for m in METHODS:
        e = np.concatenate(found[m])
        print(f"| {m} | {e.size:,} | {np.median(e):.2f} | {e.mean():.2f} | "
              f"{np.percentile(e, 90):.2f} |")


if __name__ == "__main__":
    main()
