"""A ladder map's layout from its replays (`environment.engine.ladder.MapLayout`).

From each replay's tracker events:

- **Resources and neutral units**: every neutral unit born at game loop 0. A tracker
  event gives a unit's centre rounded down to whole cells; a footprint's parity gives
  the rest: a mineral field (2 x 1 cells) is centred on a cell edge in x and a cell
  centre in y, (x, y + 0.5); a geyser (3 x 3) and a town hall (5 x 5) on a cell centre,
  (x + 0.5, y + 0.5).
- **Start locations**: the players' town halls at game loop 0.
- **Ground**: the cells where the players' ground units were reported (born, placed,
  or in a UnitPositions event) and structures were placed.

`map_layout` merges the replays of one map: the resources, neutral units, size and the
set of start locations must agree exactly (else it raises, naming the difference), and
the ground is the union of what each replay saw.
"""

from __future__ import annotations

import hashlib
import os
import pathlib
from collections.abc import Sequence

import numpy as np

from sc2jax.environment.engine.ladder import MapLayout
from sc2jax.replay_sl.archive import ReplayError, open_replay
from sc2jax.replay_sl.units import stable_unit_names, unit_table

TOWN_HALLS = frozenset({"CommandCenter", "Nexus", "Hatchery"})
FLYING = frozenset({
    "Medivac", "VikingFighter", "Liberator", "Banshee", "Raven", "Battlecruiser",
    "Overlord", "OverlordTransport", "Overseer", "OverseerSiegeMode", "Mutalisk",
    "Corruptor", "BroodLord", "Viper", "Phoenix", "VoidRay", "Oracle", "Tempest", "Carrier",
    "Interceptor", "Observer", "ObserverSiegeMode", "WarpPrism", "Mothership",
    "MothershipCore", "OverlordCocoon", "TransportOverlordCocoon", "BroodLordCocoon",
    "LocustMPFlying", "ParasiticBombDummy"})
"""Unit types that fly (with every type named "...Flying", the lifted buildings): their
positions say nothing about the ground under them."""


def is_mineral(name: str) -> bool:
    return "MineralField" in name


def is_geyser(name: str) -> bool:
    return name.endswith("Geyser")


def _walks(name: str) -> bool:
    return not (name in FLYING or name.endswith("Flying") or name.startswith("Beacon"))


def replay_layout(path: str | os.PathLike, name: str) -> MapLayout:
    """The layout one replay shows.

    Raises:
      ReplayError: for a replay that cannot be read.
    """
    replay = open_replay(path)
    description = replay.initdata["m_syncLobbyState"]["m_gameDescription"]
    size = (int(description["m_mapSizeX"]), int(description["m_mapSizeY"]))
    table = unit_table(replay)
    names = stable_unit_names()
    walking = np.array([_walks(names.get(i, "")) for i in range(max(names) + 1)], bool)
    first = table.born == 0
    minerals, geysers, neutral, starts = [], [], [], []
    for x, y, owner, kind in zip(table.x[first].tolist(), table.y[first].tolist(),
                                 table.owner[first].tolist(), table.unit_type[first].tolist()):
        kind = names.get(kind, "")
        if owner == 0 and is_mineral(kind):
            minerals.append((x, y + 0.5, kind))
        elif owner == 0 and is_geyser(kind):
            geysers.append((x + 0.5, y + 0.5, kind))
        elif owner == 0:
            neutral.append((x, y, kind))
        elif kind in TOWN_HALLS:
            starts.append((x + 0.5, y + 0.5))
    ground = np.zeros(size[::-1], bool)
    on_ground = (table.owner > 0) & walking[table.unit_type]
    _mark(ground, table.x[on_ground], table.y[on_ground])
    if len(table.positions):
        loops = np.unique(table.positions[:, 0].astype(np.int64))
        at = table.at(loops)
        step = np.searchsorted(loops, table.positions[:, 0].astype(np.int64))
        row = table.positions[:, 1].astype(np.int64)
        ok = walking[at.unit_type[step, row]] & (at.owner[step, row] > 0)
        _mark(ground, table.positions[ok, 2], table.positions[ok, 3])
    return MapLayout(name=name, map_size=size, start_locations=tuple(sorted(starts)),
                     minerals=tuple(sorted(minerals)), geysers=tuple(sorted(geysers)),
                     neutral_units=tuple(sorted(neutral)), ground=ground,
                     replays=(hashlib.sha1(pathlib.Path(path).read_bytes()).hexdigest(),))


def _mark(ground: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> None:
    x, y = np.floor(xs).astype(np.int64), np.floor(ys).astype(np.int64)
    inside = (x >= 0) & (x < ground.shape[1]) & (y >= 0) & (y < ground.shape[0])
    ground[y[inside], x[inside]] = True


_SAME = ("map_size", "start_locations", "minerals", "geysers", "neutral_units")
"""What the replays of one revision of a map agree on."""


def merge(layouts: Sequence[MapLayout]) -> MapLayout:
    """One layout from several replays' of the same map.

    Raises:
      ValueError: where they differ in anything but the ground, naming it and the
        replays.
    """
    if not layouts:
        raise ValueError("no layouts to merge")
    first = layouts[0]
    for other in layouts[1:]:
        for field in _SAME:
            if getattr(other, field) != getattr(first, field):
                raise ValueError(f"replays {first.replays[0]} and {other.replays[0]} of "
                                 f"{first.name!r} differ in {field}: "
                                 f"{getattr(first, field)} against {getattr(other, field)}")
    ground = np.logical_or.reduce([layout.ground for layout in layouts])
    return MapLayout(**{**first.__dict__, "ground": ground,
                        "replays": tuple(r for layout in layouts for r in layout.replays)})


def map_layout(paths: Sequence[str | os.PathLike], name: str, *, log=print) -> MapLayout:
    """The layout of map `name` from its replays `paths`: the most common revision's
    (a ladder map is sometimes revised: Winter's Gate LE moved two rocks by a cell),
    merged over its replays. A replay that cannot be read, or of another revision, is
    logged and left out.

    Raises:
      ValueError: if no replay is readable.
    """
    groups: dict[tuple, list[MapLayout]] = {}
    for path in paths:
        try:
            layout = replay_layout(path, name)
        except ReplayError as error:
            log(f"skipped {path}: {error.reason}")
            continue
        groups.setdefault(tuple(getattr(layout, f) for f in _SAME), []).append(layout)
    if not groups:
        raise ValueError(f"none of the {len(paths)} replays of {name!r} could be read")
    chosen = max(groups.values(), key=len)
    for group in groups.values():
        if group is not chosen:
            log(f"{name}: {len(group)} replays of another revision left out "
                f"({', '.join(sorted(r for layout in group for r in layout.replays))})")
    return merge(chosen)
