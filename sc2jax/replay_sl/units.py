"""Every unit of a replay, from its tracker events: the table observations are built from.

The tracker events record each unit's birth (or, for a structure, its placement and its
completion), its death, its type and owner changes, the positions of recently damaged
units every 240 game loops, each player's upgrades, and each player's statistics every
160 game loops. `unit_table` gathers them into arrays over the replay's units
(one row per tag: index and recycle), with the unit types as the stable ids of PySC2's
`unit_type` layer (Blizzard's stableid.json).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
import json
from typing import NamedTuple

import numpy as np

from sc2jax.replay_sl.archive import Replay

NEVER = np.iinfo(np.int32).max
"""The game loop of an event that never happened (a unit still alive at the end)."""
TAG_INDEX_BITS = 18
"""A unit's tag is (index << 18) | recycle; tracker events name units by index."""
TRACKER_EVENT = "NNet.Replay.Tracker.S"
"""The prefix of a tracker event's `_event` name."""


def unit_index(tag):
    """A unit tag's index part (an int, or an int array elementwise)."""
    return tag >> TAG_INDEX_BITS


def reported_positions(event: dict):
    """The (tag index, x, y) of each unit in a tracker UnitPositions event."""
    index, items = event["m_firstUnitIndex"], event["m_items"]
    for i in range(0, len(items) - 2, 3):
        index += items[i]
        yield index, items[i + 1], items[i + 2]


@functools.cache
def stable_unit_ids() -> dict[str, int]:
    """Unit name -> stable unit id (PySC2's unit_type values), from stableid.json."""
    data = importlib.resources.files("sc2jax.replay_sl") / "data" / "stableid.json"
    return {u["name"]: u["id"] for u in json.loads(data.read_text(encoding="utf-8"))["Units"]}


@functools.cache
def stable_unit_names() -> dict[int, str]:
    """Stable unit id -> unit name: `stable_unit_ids` inverted."""
    return {i: name for name, i in stable_unit_ids().items()}


@dataclasses.dataclass(frozen=True)
class UnitTable:
    """The replay's units, one row per unit tag (int32 arrays [U] unless said otherwise).

    Attributes:
      tag: the unit's tag (index << 18 | recycle), as game events name units (int64).
      unit_type: the stable unit id of its first type (0 where stableid has none).
      owner: its first controlling player (0: neutral).
      born: the game loop it was born or placed at.
      done: the game loop it was complete at (= born for units born complete).
      died: the game loop it died at (`NEVER` if it did not).
      x, y: float32, where it was born or placed (world units).
      type_changes: (game loop, row, new stable unit id) int32 [C, 3], in order.
      owner_changes: (game loop, row, new owner) int32 [O, 3], in order.
      positions: (game loop, row, x, y) float32 [P, 4]: damaged units' positions, in order.
      upgrades: (game loop, player, upgrade name) for each upgrade researched.
      stats: player id -> (game loops int32 [S], fields float32 [S, F]): the PlayerStats
        events' values (names in `stat_names`).
      stat_names: the PlayerStats fields, in column order.
    """

    tag: np.ndarray
    unit_type: np.ndarray
    owner: np.ndarray
    born: np.ndarray
    done: np.ndarray
    died: np.ndarray
    x: np.ndarray
    y: np.ndarray
    type_changes: np.ndarray
    owner_changes: np.ndarray
    positions: np.ndarray
    upgrades: tuple[tuple[int, int, str], ...]
    stats: dict[int, tuple[np.ndarray, np.ndarray]]
    stat_names: tuple[str, ...]

    def alive(self, game_loop: int) -> np.ndarray:
        """bool [U]: the units that exist at `game_loop` (born, not yet dead)."""
        return self.at([game_loop]).alive[0]

    def owners_at(self, game_loop: int) -> np.ndarray:
        """int32 [U]: each unit's controlling player at `game_loop`."""
        return self.at([game_loop]).owner[0]

    def types_at(self, game_loop: int) -> np.ndarray:
        """int32 [U]: each unit's stable unit id at `game_loop`."""
        return self.at([game_loop]).unit_type[0]

    def at(self, game_loops) -> UnitsAt:
        """The units' state at each of `game_loops` (ascending ints [T])."""
        loops = np.asarray(game_loops, np.int64)
        if np.any(np.diff(loops) < 0):
            raise ValueError("game_loops must be ascending")
        alive = (self.born[None, :] <= loops[:, None]) & (loops[:, None] < self.died[None, :])
        return UnitsAt(alive, _changed(self.owner, self.owner_changes, loops),
                       _changed(self.unit_type, self.type_changes, loops))


class UnitsAt(NamedTuple):
    """The units' state at T game loops (arrays [T, U], rows as `UnitTable`'s).

    Attributes:
      alive: bool: the unit exists.
      owner: int32: its controlling player.
      unit_type: int32: its stable unit id.
    """

    alive: np.ndarray
    owner: np.ndarray
    unit_type: np.ndarray


def _changed(first: np.ndarray, changes: np.ndarray, loops: np.ndarray) -> np.ndarray:
    """int32 [T, U]: `first` [U] with each change (game loop, row, value) applied from
    the first of `loops` at or after its game loop; later changes win."""
    out = np.repeat(first[None, :], len(loops), axis=0)
    starts = np.searchsorted(loops, changes[:, 0], side="left")
    due = starts < len(loops)  # Changes after the last loop change nothing.
    for start, row, value in zip(starts[due].tolist(), changes[due, 1].tolist(),
                                 changes[due, 2].tolist()):
        out[start:, row] = value
    return out


def unit_table(replay: Replay) -> UnitTable:
    """Reads every tracker event of `replay` into a `UnitTable`."""
    ids = stable_unit_ids()
    row_of: dict[int, int] = {}  # tag index -> the row of its current unit
    rows: dict[str, list] = {k: [] for k in ("tag", "unit_type", "owner", "born", "done",
                                             "died", "x", "y")}
    type_changes, owner_changes, positions, upgrades = [], [], [], []
    stats: dict[int, tuple[list, list]] = {}
    stat_names: tuple[str, ...] = ()

    def add(e, complete: bool) -> None:
        index, loop = e["m_unitTagIndex"], e["_gameloop"]
        row_of[index] = len(rows["tag"])
        for key, value in (("tag", (index << TAG_INDEX_BITS) | e["m_unitTagRecycle"]),
                           ("unit_type", ids.get(e["m_unitTypeName"].decode(), 0)),
                           ("owner", e["m_controlPlayerId"]), ("born", loop),
                           ("done", loop if complete else NEVER), ("died", NEVER),
                           ("x", e["m_x"]), ("y", e["m_y"])):
            rows[key].append(value)

    for e in replay.tracker_events():
        kind, loop = e["_event"][len(TRACKER_EVENT):], e["_gameloop"]
        if kind == "UnitBornEvent":
            add(e, complete=True)
        elif kind == "UnitInitEvent":
            add(e, complete=False)
        elif kind == "UnitDoneEvent":
            row = row_of.get(e["m_unitTagIndex"])
            if row is not None:
                rows["done"][row] = loop
        elif kind == "UnitDiedEvent":
            row = row_of.get(e["m_unitTagIndex"])
            if row is not None and rows["died"][row] == NEVER:
                rows["died"][row] = loop
        elif kind == "UnitTypeChangeEvent":
            row = row_of.get(e["m_unitTagIndex"])
            if row is not None:
                type_changes.append((loop, row, ids.get(e["m_unitTypeName"].decode(), 0)))
        elif kind == "UnitOwnerChangeEvent":
            row = row_of.get(e["m_unitTagIndex"])
            if row is not None:
                owner_changes.append((loop, row, e["m_controlPlayerId"]))
        elif kind == "UnitPositionsEvent":
            for index, x, y in reported_positions(e):
                if index in row_of:
                    positions.append((loop, row_of[index], x, y))
        elif kind == "UpgradeEvent":
            upgrades.append((loop, e["m_playerId"], e["m_upgradeTypeName"].decode()))
        elif kind == "PlayerStatsEvent":
            fields = e["m_stats"]
            stat_names = stat_names or tuple(sorted(fields))
            loops, values = stats.setdefault(e["m_playerId"], ([], []))
            loops.append(loop)
            values.append([fields.get(name, 0) for name in stat_names])
    i32 = {k: np.asarray(rows[k], np.int32) for k in ("unit_type", "owner", "born", "done",
                                                      "died")}
    return UnitTable(
        tag=np.asarray(rows["tag"], np.int64), **i32,
        x=np.asarray(rows["x"], np.float32), y=np.asarray(rows["y"], np.float32),
        type_changes=np.asarray(type_changes, np.int32).reshape(-1, 3),
        owner_changes=np.asarray(owner_changes, np.int32).reshape(-1, 3),
        positions=np.asarray(positions, np.float32).reshape(-1, 4),
        upgrades=tuple(upgrades),
        stats={p: (np.asarray(lo, np.int32), np.asarray(v, np.float32))
               for p, (lo, v) in stats.items()},
        stat_names=stat_names)
