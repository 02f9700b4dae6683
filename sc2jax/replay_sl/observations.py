"""PySC2 feature layers from a replay, without the game: the unit table seen through the
player's camera, with fog of war.

`observe_steps` draws a player's observations at a range of agent steps at once (numpy
over [steps, units] arrays), in PySC2's layer order and scales, and leaves the layers it
cannot approximate zero:

- minimap: `visibility_map`, `camera`, `player_id`, `player_relative`, `selected`,
  `unit_type`;
- screen: `visibility_map`, `player_id`, `player_relative`, `unit_type`, `selected`,
  `unit_density`, `unit_density_aa` (the count, capped as the game does),
  `build_progress` (structures under construction);
- `player` (`player_vectors`): from PlayerStats and the unit table;
- `available_actions` (`availability`).

Approximations (listed with their effects in docs/replays.md): a unit's point is an
estimate between the tracker's reports (`positions`); every unit is a disc of
`UNIT_RADIUS` and sees `SIGHT` world units; sight is computed on the map's 1 x 1 world
cells: a cell is visible when its centre lies within SIGHT of the centre of a cell that
holds one of the player's units, and a pixel is visible (2) when its centre's cell is,
else hidden (0: explored cells are not remembered); enemy units are drawn only on
visible cells (all of them with `full_information`); neutral units (minerals, geysers,
rocks) always. Terrain (height, pathable, buildable), creep, power and unit vitals are
not in replays and stay zero.
"""

from __future__ import annotations

import collections
import dataclasses
from typing import NamedTuple

import numpy as np

from sc2jax.environment.interface import narrow
from sc2jax.environment.interface.camera import Camera, Minimap
from sc2jax.environment.interface.features import (
    DENSITY,
    MINIMAP_FEATURES,
    SCREEN_FEATURES,
    UNIT_TYPE_SCALE,
)
from sc2jax.environment.interface.observation_tables import Player
from sc2jax.replay_sl.actions import ActionLabels, UnitPoints
from sc2jax.replay_sl.availability import CommandCards, available_actions, load_cards
from sc2jax.replay_sl.units import NEVER, UnitsAt, UnitTable, stable_unit_ids, unit_index

UNIT_RADIUS = 0.5
"""World units: every unit's radius (replays do not record unit footprints)."""
SIGHT = 9.0
"""World units: every unit's sight (a Marine's; replays do not record sight ranges)."""
NEUTRAL = 16
"""PySC2's `player_id` of neutral units (the tracker's owner 0)."""
_SELF, _NEUTRAL, _ENEMY = 1, 3, 4  # PySC2's player_relative values.


@dataclasses.dataclass(frozen=True)
class View:
    """What a replay is observed at.

    Attributes:
      map_size: the map's (width, height) in world units.
      screen_size, minimap_size: square layer resolutions.
      full_information: draw every enemy unit, not only those in sight (for ablations).
    """

    map_size: tuple[int, int]
    screen_size: int = 64
    minimap_size: int = 64
    full_information: bool = False

    def __post_init__(self):
        for name in ("screen_size", "minimap_size"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 256:
                raise ValueError(f"{name} must be an int in 1..256, got {value!r}")


def _eye_cells(points: np.ndarray, eyes: np.ndarray, map_size: tuple[int, int]):
    """The distinct world cells (1 x 1 units) that hold an eye, as (t, x, y): int64 [E]
    each, ordered by step t.

    Args:
      points: float32 [T, U, 2] the units' points.
      eyes: bool [T, U]: the units that see.
    """
    width, height = map_size
    t, u = np.nonzero(eyes)
    cx = np.clip(np.floor(points[t, u, 0]).astype(np.int64), 0, width - 1)
    cy = np.clip(np.floor(points[t, u, 1]).astype(np.int64), 0, height - 1)
    cells = np.unique((t * height + cy) * width + cx)  # Units on one cell see alike.
    t, rest = np.divmod(cells, height * width)
    cy, cx = np.divmod(rest, width)
    return t, cx, cy


def _inside(x: np.ndarray, y: np.ndarray, map_size: tuple[int, int]) -> np.ndarray:
    return (x >= 0) & (x < map_size[0]) & (y >= 0) & (y < map_size[1])


def _visible_grid(eyes, rows: np.ndarray, cols: np.ndarray,
                  map_size: tuple[int, int]) -> np.ndarray:
    """bool [T, I, J]: at each step t, whether the cell (cols[t, j], rows[t, i]) is on
    the map and its centre lies within SIGHT of the centre of an eye's cell.

    Each eye's disc is drawn on the rows it reaches: +1 at the first column of its span,
    -1 after the last, summed along the rows; only the queried cells are drawn, not
    the map.

    Args:
      eyes: `_eye_cells`.
      rows: int64 [T, I] cells' y.
      cols: int64 [T, J] cells' x, non-decreasing along j.
    """
    # Rows or columns that repeat (the screen has ~2.7 pixels a cell) are drawn once.
    low_row, low_col = rows.min(1, keepdims=True), cols[:, :1]
    cells_high = 1 + (rows.max(1, keepdims=True) - low_row).max(initial=0)
    cells_wide = 1 + (cols[:, -1:] - low_col).max(initial=0)
    if cells_high * cells_wide < rows.shape[1] * cols.shape[1]:
        grid = _visible_grid(eyes, low_row + np.arange(cells_high), low_col + np.arange(
            cells_wide), map_size)
        grid = np.take_along_axis(grid, (rows - low_row)[:, :, None], axis=1)
        return np.take_along_axis(grid, (cols - low_col)[:, None, :], axis=2)
    t, x, y = eyes
    steps, num_rows = rows.shape
    num_cols = cols.shape[1]
    # Eyes that reach the queried rows and columns (on the screen, few do).
    near = ((y >= rows.min(1)[t] - _SIGHT_CELLS) & (y <= rows.max(1)[t] + _SIGHT_CELLS)
            & (x >= cols[t, 0] - _SIGHT_CELLS) & (x <= cols[t, -1] + _SIGHT_CELLS))
    t, x, y = t[near], x[near], y[near]
    dy = np.abs(rows[t] - y[:, None])  # [E, I]
    e, i = np.nonzero(dy <= _SIGHT_CELLS)
    half = _SIGHT_HALF_SPAN[dy[e, i]]
    # One sorted key per (step, column), so that one searchsorted finds every span.
    keys = (np.arange(steps)[:, None] * _KEY_STRIDE + cols + _KEY_OFFSET).ravel()
    base = t[e] * _KEY_STRIDE + _KEY_OFFSET + x[e]
    first = t[e] * num_cols
    lo = np.searchsorted(keys, base - half, "left") - first
    hi = np.searchsorted(keys, base + half, "right") - first
    row = (t[e] * num_rows + i) * (num_cols + 1)
    size = steps * num_rows * (num_cols + 1)
    edges = (np.bincount(row + lo, minlength=size) - np.bincount(row + hi, minlength=size))
    seen = np.cumsum(edges.reshape(steps, num_rows, num_cols + 1), axis=2)[:, :, :num_cols]
    return (seen > 0) & _inside(cols[:, None, :], rows[:, :, None], map_size)


def _visible_points(eyes, t: np.ndarray, xs: np.ndarray, ys: np.ndarray,
                    map_size: tuple[int, int]) -> np.ndarray:
    """bool [N]: whether the cell of each world point (xs[n], ys[n]) at step t[n] is on
    the map and within SIGHT of an eye's cell (as `_visible_grid`)."""
    eye_t, eye_x, eye_y = eyes
    height = map_size[1]
    x, y = np.floor(xs).astype(np.int64), np.floor(ys).astype(np.int64)
    # The eyes of a step are ordered by row: those within SIGHT rows are a range.
    key = eye_t * height + eye_y
    start = np.searchsorted(key, t * height + np.clip(y - _SIGHT_CELLS, 0, height - 1), "left")
    count = np.searchsorted(key, t * height + np.clip(y + _SIGHT_CELLS, 0, height - 1),
                            "right") - start
    n = np.repeat(np.arange(len(t)), count)  # Every (point, nearby eye of its step) pair.
    e = np.arange(len(n)) - np.repeat(np.cumsum(count) - count - start, count)
    dy = np.abs(y[n] - eye_y[e])
    near = (dy <= _SIGHT_CELLS) & (
        np.abs(x[n] - eye_x[e]) <= _SIGHT_HALF_SPAN[np.minimum(dy, _SIGHT_CELLS)])
    return (np.bincount(n[near], minlength=len(t)) > 0) & _inside(x, y, map_size)


_SIGHT_CELLS = int(SIGHT)
_SIGHT_HALF_SPAN = np.floor(np.sqrt(SIGHT ** 2 - np.arange(_SIGHT_CELLS + 1) ** 2)).astype(
    np.int64)
"""A disc of SIGHT cells: on the row dy cells away it spans dx in [-half, half]."""
_KEY_OFFSET, _KEY_STRIDE = 1 << 20, 1 << 22  # Cells stay far inside (-2^20, 2^21).


class _Stack(NamedTuple):
    """A layer set being drawn, packed into bytes (`narrow`): `low` uint8 [T, C, S, S],
    `high` uint8 [T, W, S, S] (the wide layers' high bytes) and the set's `features`."""

    low: np.ndarray
    high: np.ndarray
    features: tuple

    @classmethod
    def zeros(cls, features, steps: int, size: int) -> _Stack:
        wide = len(narrow.wide_channels(features))
        return cls(np.zeros((steps, len(features), size, size), np.uint8),
                   np.zeros((steps, wide, size, size), np.uint8), features)

    def _channels(self, name: str) -> tuple[int, int | None]:
        """Layer `name`'s channel in `low`, and in `high` (None for a narrow layer)."""
        c = getattr(self.features, name).index
        wide = narrow.wide_channels(self.features)
        return c, wide.index(c) if c in wide else None

    def set(self, name: str, plane: np.ndarray) -> None:
        """Layer `name` = `plane` [T, S, S] (below 256 for a narrow layer)."""
        c, w = self._channels(name)
        self.low[:, c] = plane if w is None else plane & 0xFF
        if w is not None:
            self.high[:, w] = plane >> 8

    def put(self, name: str, t: np.ndarray, pixel: np.ndarray, value: np.ndarray) -> None:
        """Layer `name`[t[n], pixel[n]] = value[n] (pixel: y * S + x), in order, so a
        later value at the same place wins."""
        c, w = self._channels(name)
        area = self.low.shape[2] * self.low.shape[3]
        self.low.reshape(-1)[(t * self.low.shape[1] + c) * area + pixel] = (
            value if w is None else value & 0xFF)
        if w is not None:
            self.high.reshape(-1)[(t * self.high.shape[1] + w) * area + pixel] = value >> 8

    def packed(self, key: str) -> dict[str, np.ndarray]:
        return {key: self.low, key + narrow.HIGH_SUFFIX: self.high}


def _disc_pixels(pixels: np.ndarray, r: float, size: int) -> tuple[np.ndarray, np.ndarray]:
    """The pixels of a size x size layer that discs of radius r (at least 1/2) around
    `pixels` [N, 2] (x, y) cover: those whose centres lie within a disc, and always the
    pixel holding its centre.

    Returns:
      (disc int64 [P], pixel int64 [P]: y * size + x), ordered by disc.
    """
    centre = np.floor(pixels).astype(np.int64)
    on = np.all((centre >= 0) & (centre < size), axis=1)
    disc, pixel = np.flatnonzero(on), (centre[on, 1] * size + centre[on, 0])
    # Another pixel's centre lies 1/2 + f or 3/2 - f away along an axis (f: the point's
    # offset in its pixel), so a disc covers none unless one of those is within r (with
    # a margin: the exact test below decides).
    f = pixels - centre
    wide = np.flatnonzero(np.minimum(0.5 + f, 1.5 - f).min(axis=1) <= r + 1e-3)
    if not len(wide):
        return disc, pixel
    # A pixel o columns from the centre's has its centre more than |o| - 1/2 away: the
    # disc reaches |o| <= r + 1/2 at most.
    reach = int(np.floor(r + 0.5))
    span = np.arange(-reach, reach + 1)
    ox, oy = (a.ravel() for a in np.meshgrid(span, span))
    x = centre[wide, 0:1] + ox[None, :]  # [W, K]
    y = centre[wide, 1:2] + oy[None, :]
    inside = (x + 0.5 - pixels[wide, 0:1]) ** 2 + (y + 0.5 - pixels[wide, 1:2]) ** 2 <= r * r
    keep = inside & ((ox != 0) | (oy != 0))[None, :] & (x >= 0) & (x < size) & (y >= 0) & (
        y < size)
    disc = np.concatenate([disc, np.broadcast_to(wide[:, None], keep.shape)[keep]])
    pixel = np.concatenate([pixel, (y * size + x)[keep]])
    order = np.argsort(disc, kind="stable")
    return disc[order], pixel[order]


def _paint(stack: _Stack, t: np.ndarray, pixels: np.ndarray, radius: float,
           values: dict[str, np.ndarray], densities: bool) -> None:
    """Draws discs of `radius` pixels around `pixels` [N, 2] (x, y) of steps `t` [N] into
    the layers `values` names, later units over earlier ones; with `densities`, the
    `DENSITY` layers count the units covering each pixel. A disc covers the pixels whose
    centres lie within it, and always the pixel holding its centre."""
    steps, _, size, _ = stack.low.shape
    r = max(radius, 0.5)
    near = np.all((pixels > -r - 1) & (pixels < size + r + 1), axis=1)  # Off-layer: skip.
    unit, pixel = _disc_pixels(pixels[near], r, size)
    unit = np.flatnonzero(near)[unit]
    step = t[unit]
    # In unit order: numpy assigns repeated indices in order.
    for name, v in values.items():
        stack.put(name, step, pixel, v[unit])
    if densities:
        count = np.bincount(step * size * size + pixel,
                            minlength=steps * size * size).reshape(steps, size, size)
        for name, (multiplier, cap) in DENSITY.items():
            stack.set(name, np.minimum(count * multiplier, cap))


def render(table: UnitTable, at: UnitsAt, loops: np.ndarray, points: np.ndarray,
           cameras: np.ndarray, selected: np.ndarray, player_id: int, view: View) -> dict:
    """The player's feature layers at T game loops.

    Args:
      table: the replay's units (`unit_table`).
      at: the units' state at `loops` (`table.at(loops)`), [T, U].
      loops: int [T] game loops.
      points: float32 [T, U, 2], each unit's estimated world point.
      cameras: float32 [T, 2], the player's camera centre (world x, y).
      selected: bool [T, U], the player's selected units.
      player_id: whose view (1-based).
      view: the map's size, the resolutions and the fog setting.

    Returns:
      {"feature_screen": uint8 [T, 27, S, S], "feature_screen_high": uint8 [T, 5, S, S],
       "feature_minimap": uint8 [T, 11, M, M], "feature_minimap_high": uint8 [T, 1, M, M]}:
      the layers packed into bytes (`environment.interface.narrow`).
    """
    steps = len(loops)
    alive, owners = at.alive, at.owner
    types = np.where(at.unit_type < UNIT_TYPE_SCALE, at.unit_type, 0)  # Newer than v4: 0.
    mine = alive & (owners == player_id)
    eyes = _eye_cells(points, mine, view.map_size)
    # Units drawn: the player's, neutral, and enemies in sight (or all of them).
    enemy = alive & (owners != player_id) & (owners != 0)
    if not view.full_information:
        t, u = np.nonzero(enemy)
        enemy[t, u] = _visible_points(eyes, t, points[t, u, 0], points[t, u, 1],
                                      view.map_size)
    t, u = np.nonzero(mine | (alive & (owners == 0)) | enemy)  # By step, then unit.
    owner = owners[t, u]
    values = {"player_id": np.where(owner == 0, NEUTRAL, owner),
              "player_relative": np.where(owner == player_id, _SELF,
                                          np.where(owner == 0, _NEUTRAL, _ENEMY)),
              "unit_type": types[t, u], "selected": selected[t, u]}

    minimap = Minimap((view.minimap_size,) * 2, view.map_size)
    m = view.minimap_size
    mini = _Stack.zeros(MINIMAP_FEATURES, steps, m)
    _paint(mini, t, minimap.world_to_pixel(points[t, u]),
           UNIT_RADIUS * minimap.pixels_per_unit, values, densities=False)
    mxs, mys = minimap.pixel_centers()
    cells = lambda a: np.broadcast_to(np.floor(a).astype(np.int64), (steps, len(a)))  # noqa: E731
    mini.set("visibility_map", 2 * _visible_grid(eyes, cells(mys), cells(mxs), view.map_size))
    screen = Camera((view.screen_size,) * 2)
    half = screen.view_half_extent()
    mini.set("camera", (np.abs(mxs[None, None, :] - cameras[:, None, None, 0]) <= half[0])
             & (np.abs(mys[None, :, None] - cameras[:, None, None, 1]) <= half[1]))

    # A structure under construction: the share of its build time (from its placement to
    # its completion, a constant of its type) that has passed, in percent.
    building = (table.done[u] > loops[t]) & (table.done[u] != NEVER)
    span = np.maximum(table.done[u] - table.born[u], 1)
    progress = np.where(building, (loops[t] - table.born[u]) * 100 // span, 0)
    s = view.screen_size
    scr = _Stack.zeros(SCREEN_FEATURES, steps, s)
    centre = np.stack([cameras[t, 0], cameras[t, 1]])  # [2, N]
    _paint(scr, t, screen.world_to_pixel(centre, points[t, u]),
           UNIT_RADIUS * screen.pixels_per_unit, {**values, "build_progress": progress},
           densities=True)
    sxs, sys_ = screen.pixel_centers(cameras.T[:, :, None])  # [T, S] each
    scr.set("visibility_map", 2 * _visible_grid(
        eyes, np.floor(sys_).astype(np.int64), np.floor(sxs).astype(np.int64),
        view.map_size))
    return {**scr.packed("feature_screen"), **mini.packed("feature_minimap")}


def _count(at: UnitsAt, player_id: int, names: tuple[str, ...]) -> np.ndarray:
    """int32 [T]: the player's units of the named types."""
    ids = stable_unit_ids()
    return np.sum(at.alive & (at.owner == player_id)
                  & np.isin(at.unit_type, [ids[n] for n in names]), axis=1).astype(np.int32)


WORKERS = ("SCV", "Probe", "Drone")


def player_vectors(table: UnitTable, at: UnitsAt, loops: np.ndarray,
                   player_id: int) -> np.ndarray:
    """int32 [T, 11]: PySC2's `player` at each of `loops` (`at` = `table.at(loops)`).

    Minerals, vespene, food and active workers come from the latest PlayerStats event at
    or before each loop (zeros before the first); `food_army` is the food used less the
    workers. Idle workers are estimated at that event's loop as the player's workers
    less the active ones. Warp gates and larvae are counted in the unit table.
    `army_count` is not in replays and stays 0.
    """
    out = np.zeros((len(loops), len(Player)), np.int32)
    out[:, Player.player_id] = player_id
    out[:, Player.warp_gate_count] = _count(at, player_id, ("WarpGate",))
    out[:, Player.larva_count] = _count(at, player_id, ("Larva",))
    stat_loops, values = table.stats.get(player_id, (np.zeros(0, np.int32), None))
    i = np.searchsorted(stat_loops, loops, side="right") - 1
    known = i >= 0
    if not known.any():
        return out
    # Each field at every PlayerStats event [S] (0 where a build's events lack it).
    at_event = collections.defaultdict(lambda: np.zeros(len(stat_loops), np.float32),
                                       {name: values[:, n]
                                        for n, name in enumerate(table.stat_names)})
    # Idle workers at the events these loops read, not at every event of the game.
    events, which = np.unique(i[known], return_inverse=True)
    idle = np.maximum(0, _count(table.at(stat_loops[events]), player_id, WORKERS)
                      - at_event["m_scoreValueWorkersActiveCount"][events])
    column = {name: at_event[name][i[known]] for name in (
        "m_scoreValueWorkersActiveCount", "m_scoreValueFoodUsed", "m_scoreValueFoodMade",
        "m_scoreValueMineralsCurrent", "m_scoreValueVespeneCurrent")}
    workers = column["m_scoreValueWorkersActiveCount"]
    food_used = column["m_scoreValueFoodUsed"] // 4096
    rows = {Player.minerals: column["m_scoreValueMineralsCurrent"],
            Player.vespene: column["m_scoreValueVespeneCurrent"],
            Player.food_used: food_used,
            Player.food_cap: column["m_scoreValueFoodMade"] // 4096,
            Player.food_workers: workers,
            Player.food_army: np.maximum(0, food_used - workers),
            Player.idle_worker_count: idle[which]}
    for field, value in rows.items():
        out[known, field] = value
    return out


def unit_points(table: UnitTable, known: list[UnitPoints], alive: np.ndarray) -> np.ndarray:
    """float32 [T, U, 2]: each unit's point at T game loops: its known one (`known[t]`,
    by tag index, for the unit alive then (`alive` [T, U]) that holds the index), else
    where it was born or placed."""
    points = np.repeat(np.stack([table.x, table.y], axis=-1)[None], len(known), axis=0)
    indices = unit_index(table.tag)
    lookup = np.full(int(indices.max(initial=0)) + 1, -1, np.int64)
    for t, k in enumerate(known):
        rows = np.flatnonzero(alive[t])
        lookup[:] = -1
        lookup[indices[rows]] = rows
        inside = k.index < len(lookup)
        row = lookup[k.index[inside]]
        hit = row >= 0
        points[t, row[hit]] = k.xy[inside][hit]
    return points


def selections(table: UnitTable, chosen: list[tuple[int, ...]]) -> np.ndarray:
    """bool [T, U]: the units whose tags are in each of `chosen` (tags)."""
    row_of = dict(zip(table.tag.tolist(), range(len(table.tag))))
    out = np.zeros((len(chosen), len(table.tag)), bool)
    for t, tags in enumerate(chosen):
        out[t, [row_of[tag] for tag in tags if tag in row_of]] = True
    return out


def observe_steps(table: UnitTable, labels: ActionLabels, player_id: int, view: View,
                  steps: range, cards: CommandCards) -> dict:
    """The observations of a player's agent steps (labelled by `label_players`), at each
    step's first game loop: the units' known points, the camera and the selection then.

    Returns:
      `render`'s packed layers, "player": int32 [T, 11] and "available_actions_mask":
      bool [T, 573], for T = len(steps).
    """
    # One more step than asked: `available_actions` unites a step's and the next's.
    more = range(steps.start, min(steps.stop + 1, len(labels.steps)))
    loops = np.asarray([labels.steps[t].game_loop for t in more], np.int64)
    at = table.at(loops)
    chosen = selections(table, [labels.selections[t] for t in more])
    n = len(steps)
    now = UnitsAt(*(a[:n] for a in at))
    points = unit_points(table, [labels.unit_points[t] for t in steps], now.alive)
    cameras = np.asarray(labels.cameras[steps.start:steps.stop], np.float32)
    obs = render(table, now, loops[:n], points, cameras, chosen[:n], player_id, view)
    obs["player"] = player_vectors(table, now, loops[:n], player_id)
    obs["available_actions_mask"] = available_actions(at, chosen, obs["player"], player_id, cards)
    return obs


def observe_step(table: UnitTable, labels: ActionLabels, t: int, player_id: int,
                 view: View, cards: CommandCards | None = None) -> dict:
    """`observe_steps` of step t alone, without the leading axis, its layers unpacked
    (int32 [27, S, S] and [11, M, M]; the shipped cards by default)."""
    obs = observe_steps(table, labels, player_id, view, range(t, t + 1),
                        load_cards() if cards is None else cards)
    obs = narrow.unpack_observation(obs, SCREEN_FEATURES, MINIMAP_FEATURES)
    return {name: np.asarray(value[0]) for name, value in obs.items()}
