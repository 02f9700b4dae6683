"""How the players' game events of a folder of replays map to PySC2 functions (docs/replays.md).

    python scripts/replay_coverage.py --replays=../shared/replays --output=/tmp/coverage.json

Labels every player of every replay (`sc2jax.replay_sl.label_players`, step_mul 8, 64²)
over the machine's cores and prints, as markdown: the share of game events that map to
a function, per event kind; why the others do not; and the distribution of the labelled
functions (camera moves, selections, commands), beside the paper's 43% camera moves.
A replay that cannot be read is counted with its reason.
"""

from __future__ import annotations

import argparse
import collections
import json
import multiprocessing
import os
import pathlib
import time

from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.replay_sl import ReplayError, label_players, open_replay, read_metadata


def _one(path: str) -> dict:
    start = time.time()
    try:
        replay = open_replay(path)
        labels = label_players(replay, read_metadata(replay))
    except ReplayError as error:
        return {"path": path, "error": error.reason}
    out = {"path": path, "events": collections.Counter(), "mapped": collections.Counter(),
           "unmapped": collections.Counter(), "functions": collections.Counter(), "steps": 0,
           "seconds": 0.0}
    for label in labels.values():
        c = label.coverage
        out["events"].update(c.events)
        out["mapped"].update(c.mapped)
        out["unmapped"].update(c.unmapped)
        out["steps"] += len(label.steps)
        out["functions"].update(FUNCTIONS[s.call.function].name for s in label.steps)
    out["seconds"] = time.time() - start
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--replays", required=True, help="a folder searched for .SC2Replay")
    parser.add_argument("--output", help="also write the totals as JSON here")
    parser.add_argument("--processes", type=int, default=os.cpu_count())
    args = parser.parse_args()
    paths = sorted(str(p) for p in pathlib.Path(args.replays).rglob("*.SC2Replay"))
    if not paths:
        raise SystemExit(f"no .SC2Replay files under {args.replays!r}")
    total = {k: collections.Counter() for k in ("events", "mapped", "unmapped", "functions")}
    errors, steps, seconds = collections.Counter(), 0, 0.0
    start = time.time()
    with multiprocessing.Pool(args.processes) as pool:
        for i, result in enumerate(pool.imap_unordered(_one, paths, chunksize=4), 1):
            if "error" in result:
                errors[result["error"]] += 1
            else:
                for k in total:
                    total[k].update(result[k])
                steps += result["steps"]
                seconds += result["seconds"]
            if i % 50 == 0 or i == len(paths):
                print(f"<!-- {i}/{len(paths)} replays, {time.time() - start:.0f} s -->",
                      flush=True)
    wall = time.time() - start
    print(f"\n{len(paths)} replays ({sum(errors.values())} unreadable), {steps:,} agent steps "
          f"of both players; {wall:.0f} s on {args.processes} processes "
          f"({seconds / max(1, len(paths) - sum(errors.values())):.2f} s per replay "
          f"per process)\n")
    print("| game event | events | mapped | share |\n|---|---:|---:|---:|")
    for kind, n in total["events"].most_common():
        print(f"| {kind} | {n:,} | {total['mapped'][kind]:,} | "
              f"{100 * total['mapped'][kind] / n:.1f}% |")
    all_events, all_mapped = sum(total["events"].values()), sum(total["mapped"].values())
    print(f"| all | {all_events:,} | {all_mapped:,} | {100 * all_mapped / all_events:.1f}% |\n")
    print("| not mapped | events |\n|---|---:|")
    for reason, n in total["unmapped"].most_common(25):
        print(f"| {reason} | {n:,} |")
    acted = steps - total["functions"]["no_op"]
    print(f"\n{acted:,} of {steps:,} agent steps have an action ({100 * acted / steps:.1f}%).\n")
    print("| function | steps | share of steps with an action |\n|---|---:|---:|")
    for name, n in total["functions"].most_common(30):
        if name != "no_op":
            print(f"| {name} | {n:,} | {100 * n / acted:.1f}% |")
    for reason, n in errors.items():
        print(f"\nUnreadable: {reason} ({n})")
    if args.output:
        with open(args.output, "w") as f:
            json.dump({k: dict(v) for k, v in total.items()} | {
                "errors": dict(errors), "steps": steps, "wall_s": wall}, f, indent=1)


if __name__ == "__main__":
    main()
