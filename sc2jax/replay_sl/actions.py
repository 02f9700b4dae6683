"""A human player's game events -> PySC2 function calls, one per agent step.

At the paper's step multiplier of 8, agent step t covers game loops [8t, 8t + 8). Its
label is the first of the player's actions in those loops that maps to a PySC2 function,
else `no_op`, as in the paper's section 5. The events map as follows:

- a camera update: `move_camera` at the camera's new centre on the minimap;
- a selection delta that adds one unit: `select_point` at the unit's screen point
  (select, or toggle where the rest is kept); several units: `select_rect` around
  their screen points (select, or add); units only removed: `select_point` toggle at
  the first removed unit;
- a control group's set, add, recall, or set or add with steal: `select_control_group`;
- a command with an ability: `<Ability>_screen`, `_minimap` (by the command's minimap
  flag), `_quick` or `_autocast`; without an ability (a right click): `Smart_screen` or
  `Smart_minimap`;
- a command's target update (the same command again, to a new target): the last
  command's function at the new target.

Screen points are the world point projected through the camera (orthographic, 24 world
units across the screen's longer side), clipped to the screen. A unit's world point is
its last tracker report (born, placed, or in a positions event), then a walk at its
type's speed towards the target of each later command of its player (`_Positions`); a
unit of a type that does not move (a structure given a rally point) stays.
What cannot be represented (a deleted control group, saved cameras, a command whose
ability PySC2 has no function for) is counted in `Coverage`, never guessed.
"""

from __future__ import annotations

import collections
import dataclasses
import heapq
from typing import NamedTuple

import numpy as np

from sc2jax.checks import check_positive_int
from sc2jax.environment.interface.camera import Camera, Minimap
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, FunctionType
from sc2jax.replay_sl.abilities import resolve
from sc2jax.replay_sl.archive import Replay
from sc2jax.replay_sl.metadata import ReplayMetadata
from sc2jax.replay_sl.movement import speed, walk
from sc2jax.replay_sl.units import TRACKER_EVENT, reported_positions, stable_unit_ids, unit_index

STEP_MUL = 8
ACTIVE_SELECTION = 10  # The control group id of the current selection in selection deltas.
MINIMAP_FLAG = 0x10000  # A command's flag: issued on the minimap.
QUEUED_FLAG = 0x2
AUTOCAST_FLAG = 0x40
_GROUP_ACTS = {0: "set", 1: "append", 2: "recall", 4: "set_and_steal", 5: "append_and_steal"}
NOT_REPRESENTABLE = {
    "SCameraSaveEvent": "saving a camera location (PySC2 has no function for it)",
}
"""Player actions that PySC2's functions cannot express, and why."""


@dataclasses.dataclass(frozen=True)
class Step:
    """One agent step's label.

    Attributes:
      game_loop: the step's first game loop (a multiple of step_mul).
      call: the PySC2 function call (`no_op` where the player did nothing mappable).
      event: the game event's kind that gave the call ("" for no_op).
    """

    game_loop: int
    call: FunctionCall
    event: str = ""


class Order(NamedTuple):
    """A command with a target point, to the units selected when it was given.

    Attributes:
      game_loop: when it was given.
      units: the selected units that move (`movement`), by tag index (as tracker events
        name units).
      x, y: the target point (world units).
    """

    game_loop: int
    units: tuple[int, ...]
    x: float
    y: float


@dataclasses.dataclass
class Coverage:
    """How the player's game events mapped.

    Attributes:
      events: game events of the player, by kind (the part after `NNet.Game.S`).
      mapped: of those, the ones that map to a PySC2 function call.
      unmapped: the reasons the others do not, with counts.
      labelled: mapped events that became a step's label (the first in their step).
    """

    events: collections.Counter = dataclasses.field(default_factory=collections.Counter)
    mapped: collections.Counter = dataclasses.field(default_factory=collections.Counter)
    unmapped: collections.Counter = dataclasses.field(default_factory=collections.Counter)
    labelled: int = 0


class _Walk(NamedTuple):
    """A unit walking from `start` at `game_loop` towards `target`, `speed` a loop."""

    game_loop: int
    start: tuple[float, float]
    target: tuple[float, float]
    speed: float


class _Positions:
    """Each unit's estimated world point: its last tracker report (birth, placement or a
    positions event), then a walk at its type's speed towards the target of each command
    its player gives it (`positions`' "move" estimate).

    Attributes:
      at: tag index -> (x, y), for the units standing.
      walks: tag index -> its `_Walk`, for the units walking.
      types: tag index -> its stable unit id now.
      changes: how many times `at` or `walks` changed.
    """

    def __init__(self):
        self.at: dict[int, tuple[float, float]] = {}
        self.walks: dict[int, _Walk] = {}
        self.types: dict[int, int] = {}
        self.changes = 0
        self._last: tuple[int, UnitPoints] | None = None  # (changes, points) of `points`.

    def point(self, index: int, game_loop: int) -> tuple[float, float] | None:
        """A unit's point at `game_loop` (not before the last change), if known."""
        w = self.walks.get(index)
        if w is None:
            return self.at.get(index)
        return walk(w.start, w.target, w.speed, max(game_loop - w.game_loop, 0))

    def get(self, tag: int, game_loop: int) -> tuple[float, float] | None:
        return self.point(unit_index(tag), game_loop)

    def move(self, units, world, game_loop: int) -> tuple[int, ...]:
        """Sends the units of a type that moves (`movement`) towards `world` from where
        they are at `game_loop` (a unit never seen is put there); returns them."""
        moving = tuple(i for i in units if speed(self.types.get(i, 0)) > 0)
        target = (float(world[0]), float(world[1]))
        for index in moving:
            start = self.point(index, game_loop)
            if start is None:
                self.at[index] = target
            else:
                self.at.pop(index, None)
                self.walks[index] = _Walk(game_loop, start, target, speed(self.types[index]))
        self.changes += 1
        return moving

    def snapshot(self, game_loop: int) -> dict[int, tuple[float, float]]:
        """Every known unit's point at `game_loop`; walks that have ended stand from then."""
        now = dict(self.at)
        for index, w in self.walks.items():  # Snapshots come in order: loops >= the walks'.
            now[index] = walk(w.start, w.target, w.speed, game_loop - w.game_loop)
        for index in [i for i, w in self.walks.items() if now[i] == w.target]:
            self.at[index] = self.walks.pop(index).target
            self.changes += 1
        return now

    def points(self, game_loop: int) -> UnitPoints:
        """`snapshot` as read-only arrays, the last ones again while nothing has changed
        and nobody walks."""
        if self._last is None or self.walks or self._last[0] != self.changes:
            now = self.snapshot(game_loop)
            index = np.fromiter(now, np.int64, len(now))
            xy = np.asarray(list(now.values()), np.float32).reshape(-1, 2)
            index.flags.writeable = xy.flags.writeable = False
            self._last = (self.changes, UnitPoints(index, xy))
        return self._last[1]

    def tracker(self, event: dict) -> None:
        kind = event["_event"][len(TRACKER_EVENT):]
        index = event.get("m_unitTagIndex")
        if kind in ("UnitBornEvent", "UnitInitEvent", "UnitTypeChangeEvent"):
            self.types[index] = stable_unit_ids().get(event["m_unitTypeName"].decode(), 0)
        if kind in ("UnitBornEvent", "UnitInitEvent"):
            self.at[index] = (float(event["m_x"]), float(event["m_y"]))
            self.walks.pop(index, None)
        elif kind == "UnitPositionsEvent":
            for index, x, y in reported_positions(event):
                self.at[index] = (float(x), float(y))
                self.walks.pop(index, None)
        elif kind == "UnitDiedEvent":
            self.at.pop(index, None)
            self.walks.pop(index, None)
        else:
            return
        self.changes += 1


def _point(data: dict, scale: float = 4096.0) -> tuple[float, float]:
    return data["x"] / scale, data["y"] / scale


def removed_indices(length: int, bits: int) -> set[int]:
    """The selection indices a remove mask names, from s2protocol's (length, bits).

    The game writes the mask as its whole bytes, in order (index 8k + j is bit j of byte
    k), then the `length % 8` indices left over; s2protocol reads the `length` bits as one
    integer, the first read on top. So byte k is the integer's bits
    [length - 8k - 8, length - 8k) and the leftover indices its lowest bits (sc2reader's
    `read_selection_bitmask` reads them so; scripts/selection_tracking.py measures it).
    """
    whole, rest = divmod(length, 8)
    out = {whole * 8 + j for j in range(rest) if (bits >> j) & 1}
    for k in range(whole):
        byte = (bits >> (length - 8 * k - 8)) & 0xFF
        out.update(8 * k + j for j in range(8) if (byte >> j) & 1)
    return out


def _apply_remove(units: list[int], mask: dict) -> list[int]:
    """The units a selection delta's remove mask keeps, in order."""
    kind, value = next(iter(mask.items()))
    if kind == "ZeroIndices":  # The indices kept.
        return [units[i] for i in value if i < len(units)]
    if kind == "OneIndices":  # The indices removed.
        drop = set(value)
        return [t for i, t in enumerate(units) if i not in drop]
    if kind == "Mask":
        drop = removed_indices(*value)
        return [t for i, t in enumerate(units) if i not in drop]
    return list(units)  # "None": nothing removed.


def _apply_delta(units: list[int], delta: dict) -> list[int]:
    return sorted(set(_apply_remove(units, delta["m_removeMask"]))
                  | set(delta["m_addUnitTags"]))


class _Labeller:
    """Turns one player's events, in game-loop order, into function calls."""

    def __init__(self, metadata: ReplayMetadata, map_size: tuple[int, int],
                 screen_size: int, minimap_size: int, positions: _Positions):
        self.build = metadata.base_build
        self.screen = Camera((screen_size, screen_size))
        self.minimap = Minimap((minimap_size, minimap_size), map_size)
        self.size, self.minimap_size = screen_size, minimap_size
        self.camera = (map_size[0] / 2, map_size[1] / 2)
        self.positions = positions
        self.selection: list[int] = []
        self.last_command: tuple[int, int] | None = None  # (function, command flags)
        self.loop = 0
        self.orders: list[Order] = []
        self.group_loop = -1
        self.groups: dict[int, list[int]] = {}  # Control group index -> its units' tags.
        self.before_recall: list[int] | None = None

    # Projections, of numpy [1, 2] points so that the transforms run on numpy, not jax.
    def screen_xy(self, world) -> list[int]:
        px = self.screen.world_to_pixel(np.asarray(self.camera, np.float32),
                                        np.asarray([world], np.float32))[0]
        return [int(min(max(float(v), 0.0), self.size - 1)) for v in px]

    def minimap_xy(self, world) -> list[int]:
        px = self.minimap.world_to_pixel(np.asarray([world], np.float32))[0]
        return [int(min(max(float(v), 0.0), self.minimap_size - 1)) for v in px]

    # Events.
    def event(self, e: dict) -> tuple[FunctionCall | None, str]:
        """The event's call, or None and the reason it has none."""
        kind = e["_event"]
        self.loop = e["_gameloop"]
        name = kind.rsplit(".", 1)[-1]
        if name in NOT_REPRESENTABLE:
            return None, NOT_REPRESENTABLE[name]
        handler = getattr(self, "_" + name, None)
        if handler is None:
            return None, "not an action"
        return handler(e)

    def _SCameraUpdateEvent(self, e):
        if e["m_target"] is None:
            return None, "camera update without a target (zoom or follow)"
        self.camera = _point(e["m_target"], 256.0)
        return FUNCTIONS.move_camera(self.minimap_xy(self.camera)), ""

    def _SControlGroupUpdateEvent(self, e):
        act = _GROUP_ACTS.get(e["m_controlGroupUpdate"])
        index = e["m_controlGroupIndex"]
        self.group_loop = e["_gameloop"]
        self.before_recall = None
        if act is None:
            self.groups.pop(index, None)
            return None, "control group deleted"
        if act.endswith("steal"):
            for other, tags in self.groups.items():
                self.groups[other] = [t for t in tags if t not in self.selection]
        if act.startswith("set"):
            self.groups[index] = list(self.selection)
        elif act.startswith("append"):
            self.groups[index] = sorted(set(self.groups.get(index, ())) | set(self.selection))
        else:  # recall
            self.before_recall = self.selection
            self.selection = list(self.groups.get(index, ()))
        return FUNCTIONS.select_control_group(act, index), ""

    def _SSelectionDeltaEvent(self, e):
        group, delta = e["m_controlGroupId"], e["m_delta"]
        if group != ACTIVE_SELECTION:  # The game's update of a group (units morphed, died).
            self.groups[group] = _apply_delta(self.groups.get(group, []), delta)
            return None, "control group delta (follows a control group event)"
        echo = e["_gameloop"] == self.group_loop
        # A recall's own delta, when the game writes one, is the game's account of it.
        base = self.before_recall if echo and self.before_recall is not None else self.selection
        kept = _apply_remove(base, delta["m_removeMask"])
        removed = [t for t in base if t not in kept]
        added = list(delta["m_addUnitTags"])
        self.selection = sorted(set(kept) | set(added))
        if echo:
            return None, "selection of a control group (follows a control group event)"
        if not added:
            if not removed:
                return None, "empty selection delta"
            return self._select_point("toggle", removed[0])
        if len(added) == 1:
            return self._select_point("toggle" if kept else "select", added[0])
        points = [p for p in (self.positions.get(tag, self.loop) for tag in added)
                  if p is not None]
        if not points:
            return None, "selected units with unknown positions"
        xs, ys = zip(*(self.screen_xy(p) for p in points))
        return FUNCTIONS.select_rect("add" if kept else "select", [min(xs), min(ys)],
                                     [max(xs), max(ys)]), ""

    def _select_point(self, act, tag):
        point = self.positions.get(tag, self.loop)
        if point is None:
            return None, "selected unit with an unknown position"
        return FUNCTIONS.select_point(act, self.screen_xy(point)), ""

    def _SCmdEvent(self, e):
        data, flags = e["m_data"], e["m_cmdFlags"]
        target = next(iter(data)) if isinstance(data, dict) else "None"
        if target == "TargetPoint":
            world = _point(data["TargetPoint"])
        elif target == "TargetUnit":
            world = _point(data["TargetUnit"]["m_snapshotPoint"])
        else:
            world = None
        kind = (FunctionType.autocast if flags & AUTOCAST_FLAG else FunctionType.cmd_quick
                if world is None else FunctionType.cmd_minimap if flags & MINIMAP_FLAG
                else FunctionType.cmd_screen)
        if e["m_abil"] is None:
            if world is None:
                return None, "right click without a target"
            function = (FUNCTIONS.Smart_minimap if kind == FunctionType.cmd_minimap
                        else FUNCTIONS.Smart_screen).id
        else:
            abil = e["m_abil"]
            resolved = resolve(self.build, abil["m_abilLink"], abil["m_abilCmdIndex"], kind)
            if resolved.function is None:
                return None, f"no PySC2 function for {resolved.name} ({kind.name})"
            function = resolved.function
        self.last_command = (function, flags)
        return self._command(function, flags, world)

    def _command(self, function: int, flags: int, world):
        f = FUNCTIONS[function]
        args = []
        for arg in f.args:
            if arg.name == "queued":
                args.append([int(bool(flags & QUEUED_FLAG))])
            elif arg.name == "screen":
                args.append(self.screen_xy(world))
            elif arg.name == "minimap":
                args.append(self.minimap_xy(world))
        if world is not None:  # The commanded units that move walk towards it.
            units = self.positions.move([unit_index(tag) for tag in self.selection], world,
                                        self.loop)
            self.orders.append(Order(self.loop, units, float(world[0]), float(world[1])))
        return FunctionCall(f.id, args), ""

    def _SCmdUpdateTargetPointEvent(self, e):
        return self._update(_point(e["m_target"]))

    def _SCmdUpdateTargetUnitEvent(self, e):
        return self._update(_point(e["m_target"]["m_snapshotPoint"]))

    def _update(self, world):
        if self.last_command is None:
            return None, "target update without a command"
        function, flags = self.last_command
        if not any(a.name in ("screen", "minimap") for a in FUNCTIONS[function].args):
            return None, "target update of a command without a point"
        return self._command(function, flags, world)


def _merged(replay: Replay, user_ids: set[int]):
    """The players' game events and every tracker event, in game-loop order (tracker
    events first within a loop: they record the state that loop's actions saw)."""
    game = ((e["_gameloop"], 1, i, e) for i, e in enumerate(replay.game_events())
            if e["_userid"]["m_userId"] in user_ids)
    tracker = ((e["_gameloop"], 0, i, e) for i, e in enumerate(replay.tracker_events()))
    for _, source, _, e in heapq.merge(game, tracker, key=lambda t: t[:3]):
        yield source, e


class UnitPoints(NamedTuple):
    """Every unit's last known world point at one game loop (see `_Positions`).

    Attributes:
      index: int64 [K] tag indices.
      xy: float32 [K, 2] their points.
    """

    index: np.ndarray
    xy: np.ndarray


@dataclasses.dataclass
class ActionLabels:
    """A player's labels and what the player saw, per agent step.

    Attributes:
      steps: `steps[t]` for agent step t.
      coverage: how the player's events mapped.
      orders: the player's commands with a target point, in order.
      cameras: float32 [T, 2], the camera's centre at each step's first loop.
      selections: the selected units' tags at each step's first loop.
      unit_points: every unit's known point at each step's first loop (shared by the
        players labelled together).
    """

    steps: list[Step]
    coverage: Coverage
    orders: list[Order] = dataclasses.field(default_factory=list)
    cameras: np.ndarray | None = None
    selections: list[tuple[int, ...]] = dataclasses.field(default_factory=list)
    unit_points: list[UnitPoints] = dataclasses.field(default_factory=list)


def label_actions(replay: Replay, metadata: ReplayMetadata, player_id: int, *,
                  screen_size: int = 64, minimap_size: int = 64,
                  step_mul: int = STEP_MUL) -> ActionLabels:
    """PySC2 function calls of one player, one per agent step of `step_mul` game loops.

    Args:
      replay, metadata: the replay (`open_replay`) and its metadata (`read_metadata`).
      player_id: 1-based.
      screen_size, minimap_size: the feature layers' resolution the points are in.
      step_mul: game loops per agent step (8 in the paper).

    Raises:
      ValueError: for a player not in the replay, or a bad size or step_mul.
    """
    return label_players(replay, metadata, (player_id,), screen_size=screen_size,
                         minimap_size=minimap_size, step_mul=step_mul)[player_id]


def label_players(replay: Replay, metadata: ReplayMetadata, player_ids=None, *,
                  screen_size: int = 64, minimap_size: int = 64,
                  step_mul: int = STEP_MUL) -> dict[int, ActionLabels]:
    """`label_actions` for several players (default: all) in one pass over the events.

    Returns:
      player id -> its `ActionLabels`.
    """
    for name, value in (("screen_size", screen_size), ("minimap_size", minimap_size),
                        ("step_mul", step_mul)):
        check_positive_int(name, value)
    players = [metadata.player(p) for p in (player_ids or [p.player_id for p in
                                                           metadata.players])]
    description = replay.initdata["m_syncLobbyState"]["m_gameDescription"]
    map_size = (int(description["m_mapSizeX"]), int(description["m_mapSizeY"]))
    num_steps = replay.game_loops // step_mul + 1
    positions = _Positions()  # Shared: the tracker's points are every player's.
    labellers = {p.user_id: _Labeller(metadata, map_size, screen_size, minimap_size, positions)
                 for p in players}
    coverage = {u: Coverage() for u in labellers}
    calls = {u: [None] * num_steps for u in labellers}
    cameras = {u: np.zeros((num_steps, 2), np.float32) for u in labellers}
    selections: dict[int, list[tuple[int, ...]]] = {u: [] for u in labellers}
    unit_points: list[UnitPoints] = []

    def snapshot(until: int) -> None:
        """Records the state at the first loop of every step that starts before `until`."""
        while len(unit_points) < num_steps and len(unit_points) * step_mul < until:
            t = len(unit_points)
            unit_points.append(positions.points(t * step_mul))
            for user, labeller in labellers.items():
                cameras[user][t] = labeller.camera
                selections[user].append(tuple(labeller.selection))

    for source, e in _merged(replay, set(labellers)):
        # Step t's state (at loop t * step_mul) includes that loop's tracker events but
        # not the player's actions in it: a game event at loop L closes the steps
        # starting at or before L, a tracker event those starting before L.
        snapshot(e["_gameloop"] + source)
        if source == 0:
            positions.tracker(e)
            continue
        user = e["_userid"]["m_userId"]
        kind = e["_event"].rsplit(".", 1)[-1][1:]
        coverage[user].events[kind] += 1
        call, reason = labellers[user].event(e)
        if call is None:
            coverage[user].unmapped[f"{kind}: {reason}"] += 1
            continue
        coverage[user].mapped[kind] += 1
        t = min(e["_gameloop"] // step_mul, num_steps - 1)
        if calls[user][t] is None:
            calls[user][t] = (call, kind)
            coverage[user].labelled += 1
    snapshot(num_steps * step_mul)
    no_op = FunctionCall(FUNCTIONS.no_op.id, [])
    return {p.player_id: ActionLabels(
        [Step(t * step_mul, *(c if c is not None else (no_op, "")))
         for t, c in enumerate(calls[p.user_id])], coverage[p.user_id],
        labellers[p.user_id].orders, cameras[p.user_id], selections[p.user_id],
        unit_points) for p in players}
