r"""Writes the packaged ladder-map layouts (`environment.engine.ladder`) from replays.

    python scripts/ladder_layouts.py --replays=../shared/replays \
        --figure="Disco Bloodbath LE=docs/figures/ladder_disco_bloodbath.png"

For every map with at least --min_replays replays in the folder's MANIFEST.json (by its
English name), it merges the replays of the map's most common revision
(`replay_sl.layouts.map_layout`) and writes
sc2jax/environment/engine/data/ladder/<map>.json, atomically. --figure draws one map's
layout: its ground, resources, start locations and neutral units.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import pathlib
import time

from sc2jax.atomic import atomic_write
from sc2jax.environment.engine import ladder
from sc2jax.replay_sl.layouts import map_layout

OUTPUT = pathlib.Path(ladder.__file__).parent / ladder.DATA


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--replays", required=True, help="A folder with MANIFEST.json.")
    parser.add_argument("--min_replays", type=int, default=15)
    parser.add_argument("--figure", default="", help="MAP=PNG: draw that map's layout.")
    args = parser.parse_args()
    figure = args.figure.split("=", 1) if args.figure else None
    if figure is not None and len(figure) != 2:
        raise SystemExit(f"error: --figure must be MAP=PNG, got {args.figure!r}")
    manifest = json.loads((pathlib.Path(args.replays) / "MANIFEST.json").read_text())
    by_map = collections.defaultdict(list)
    for replay in manifest["replays"]:
        by_map[replay["map"]].append(os.path.join(args.replays, replay["file"]))
    maps = sorted(m for m, files in by_map.items()
                  if len(files) >= args.min_replays and m.isascii())
    if not maps:
        raise SystemExit(f"error: no map has {args.min_replays} replays in {args.replays}")
    OUTPUT.mkdir(parents=True, exist_ok=True)
    for name in maps:
        start = time.time()
        layout = map_layout(by_map[name], name)
        with atomic_write(OUTPUT / ladder.file_name(name)) as f:
            json.dump(layout.to_json(), f, separators=(",", ":"))
        print(f"{name}: {len(layout.replays)} of {len(by_map[name])} replays, "
              f"{len(layout.minerals)} mineral fields, {len(layout.geysers)} geysers, "
              f"{layout.ground.sum()} ground cells, playable {layout.playable} "
              f"({time.time() - start:.0f} s)", flush=True)
        if figure is not None and figure[0] == name:
            draw(layout, figure[1])


def draw(layout: ladder.MapLayout, path: str) -> None:
    """A picture of a layout: ground cells grey, resources, starts and neutral units."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(6, 5.5))
    ax.imshow(layout.ground, origin="lower", cmap="Greys", vmin=0, vmax=2,
              extent=(0, layout.map_size[0], 0, layout.map_size[1]))
    for field, style in (("minerals", dict(s=3, c="tab:blue", label="mineral fields")),
                         ("geysers", dict(s=12, c="tab:green", label="geysers")),
                         ("neutral_units", dict(s=12, c="tab:orange", marker="x",
                                                label="rocks and towers")),
                         ("start_locations", dict(s=40, c="tab:red", marker="s",
                                                  label="start locations"))):
        points = np.array([p[:2] for p in getattr(layout, field)], float)
        ax.scatter(points[:, 0], points[:, 1], **style)
    ax.set_title(f"{layout.name}: seen ground and placements, {len(layout.replays)} replays")
    ax.legend(fontsize=7, loc="lower right")
    with atomic_write(path, "wb") as f:
        fig.savefig(f, format="png", dpi=80)
    plt.close(fig)


if __name__ == "__main__":
    main()
