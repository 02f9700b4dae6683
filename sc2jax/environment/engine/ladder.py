"""Ladder maps' layouts, re-created from professional replays (`replay_sl.layouts`).

A replay holds no terrain, but its tracker events place every unit at its birth, from
the first game loop: the mineral fields and geysers, the players' starting town halls,
the rocks and towers. `MapLayout` keeps those with the map's size, and the ground
that units were seen to stand on over many replays of the map, the stand-in for the
pathable terrain (docs/fidelity.md). `scripts/ladder_layouts.py` writes the packaged
layouts from `../shared/replays`; `load_layout` reads one.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
import json
import re

import numpy as np

DATA = "data/ladder"


@dataclasses.dataclass(frozen=True)
class MapLayout:
    """One ladder map, as its replays show it (world units; x right, y up).

    Attributes:
      name: the map's English name ("Disco Bloodbath LE").
      map_size: (width, height) in cells, as the game description gives it.
      start_locations: ((x, y), ...) the centres of the players' first town halls.
      minerals: ((x, y, unit type name), ...) every mineral field's centre.
      geysers: ((x, y, unit type name), ...) every vespene geyser's centre.
      neutral_units: ((x, y, unit type name), ...) the other neutral units of the first
        game loop (rocks, debris, collapsible towers, Xel'Naga towers), at the cell the
        tracker events give: their centre, rounded down.
      ground: bool [height, width]: cells a ground unit stood on or a structure was
        placed on in any of the replays (row y, column x).
      playable: (x0, y0, x1, y1): the smallest box holding every `ground` cell (cells
        x0 <= x < x1, y0 <= y < y1).
      replays: the SHA-1s of the replays merged.
    """

    name: str
    map_size: tuple[int, int]
    start_locations: tuple[tuple[float, float], ...]
    minerals: tuple[tuple[float, float, str], ...]
    geysers: tuple[tuple[float, float, str], ...]
    neutral_units: tuple[tuple[float, float, str], ...]
    ground: np.ndarray
    replays: tuple[str, ...]

    @property
    def playable(self) -> tuple[int, int, int, int]:
        ys, xs = np.nonzero(self.ground)
        return int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1

    def to_json(self) -> dict:
        """A JSON-ready dict (`from_json` reads it back); `ground` as rows of '0'/'1',
        the top row (largest y) first, as the map is drawn."""
        out = dataclasses.asdict(dataclasses.replace(self, ground=None))
        out["ground"] = ["".join("1" if v else "0" for v in row) for row in self.ground[::-1]]
        return out

    @classmethod
    def from_json(cls, data: dict) -> MapLayout:
        ground = np.array([[c == "1" for c in row] for row in data["ground"]][::-1], bool)
        return cls(name=data["name"], map_size=tuple(data["map_size"]),
                   start_locations=tuple(tuple(p) for p in data["start_locations"]),
                   minerals=tuple(tuple(m) for m in data["minerals"]),
                   geysers=tuple(tuple(g) for g in data["geysers"]),
                   neutral_units=tuple(tuple(d) for d in data["neutral_units"]),
                   ground=ground, replays=tuple(data["replays"]))


def file_name(map_name: str) -> str:
    """The packaged file of a map: "Disco Bloodbath LE" -> "disco_bloodbath_le.json"."""
    return re.sub(r"[^a-z0-9]+", "_", map_name.lower()).strip("_") + ".json"


def _folder():
    return importlib.resources.files("sc2jax.environment.engine") / DATA


def layouts() -> tuple[str, ...]:
    """The names of the packaged layouts."""
    names = []
    for entry in _folder().iterdir():
        if entry.name.endswith(".json"):
            names.append(json.loads(entry.read_text(encoding="utf-8"))["name"])
    return tuple(sorted(names))


@functools.cache
def load_layout(map_name: str) -> MapLayout:
    """The packaged layout of `map_name`.

    Raises:
      ValueError: for a map without one, naming those there are.
    """
    path = _folder() / file_name(map_name)
    if not path.is_file():
        raise ValueError(f"no layout of map {map_name!r}; the packaged ones: {list(layouts())}")
    return MapLayout.from_json(json.loads(path.read_text(encoding="utf-8")))
