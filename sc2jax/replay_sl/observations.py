"""PySC2 feature layers from a replay, without the game: the unit table seen through the
player's camera, with fog of war.

`observe` draws, at one game loop and for one player, the layers that the replay can
approximate, in PySC2's layer order and scales, and leaves the others zero:

- minimap: `visibility_map`, `camera`, `player_id`, `player_relative`, `selected`,
  `unit_type`;
- screen: `visibility_map`, `player_id`, `player_relative`, `unit_type`, `selected`,
  `unit_density`, `unit_density_aa` (the count, capped as the game does),
  `build_progress` (structures under construction);
- `player`: `player_id`, minerals, vespene, food used and cap, and workers from the
  latest PlayerStats event.

Approximations (listed with their effects in docs/replays.md): a unit's point is an
estimate between the tracker's reports (`positions`); every unit is a disc of
`UNIT_RADIUS` and sees `SIGHT` world units; a pixel is visible (2) when a unit of the
player sees it, else hidden (0: explored cells are not remembered); enemy units are
drawn only where visible (all of them with `full_information`); neutral units (minerals,
geysers, rocks) always. Terrain (height, pathable, buildable), creep, power and unit
vitals are not in replays and stay zero.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sc2jax.environment.interface.camera import Camera, Minimap
from sc2jax.environment.interface.features import (
    DENSITY,
    MINIMAP_FEATURES,
    SCREEN_FEATURES,
    UNIT_TYPE_SCALE,
)
from sc2jax.environment.interface.observation_tables import Player
from sc2jax.replay_sl.actions import ActionLabels, UnitPoints
from sc2jax.replay_sl.units import NEVER, UnitTable, unit_index

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


def _visible(eyes: np.ndarray, xs: np.ndarray, ys: np.ndarray):
    """bool [len(ys), len(xs)]: cells whose centre lies within SIGHT of an eye."""
    if not len(eyes):
        return np.zeros((len(ys), len(xs)), bool)
    dx = xs[None, :, None] - eyes[None, None, :, 0]
    dy = ys[:, None, None] - eyes[None, None, :, 1]
    return ((dx * dx + dy * dy) <= SIGHT * SIGHT).any(-1)


def _paint(layers: dict[str, np.ndarray], pixels: np.ndarray, radius: float,
           values: dict[str, np.ndarray], size: int) -> None:
    """Draws discs of `radius` pixels around `pixels` [N, 2] (x, y) into `layers`, later
    units over earlier ones; the `DENSITY` layers among `layers` count the units covering
    each pixel. A disc covers the pixels whose centres lie within it, and always the pixel
    holding its centre."""
    if not len(pixels):
        return
    r = max(radius, 0.5)
    span = np.arange(-int(np.ceil(r)), int(np.ceil(r)) + 1)
    ox, oy = (a.ravel() for a in np.meshgrid(span, span))
    centre = np.floor(pixels).astype(np.int64)
    x = centre[:, 0:1] + ox[None, :]  # [N, K]
    y = centre[:, 1:2] + oy[None, :]
    inside = (x + 0.5 - pixels[:, 0:1]) ** 2 + (y + 0.5 - pixels[:, 1:2]) ** 2 <= r * r
    keep = (inside | ((ox == 0) & (oy == 0))[None, :]) & (x >= 0) & (x < size) & (y >= 0) & (
        y < size)
    unit = np.broadcast_to(np.arange(len(pixels))[:, None], keep.shape)[keep]
    flat = (y * size + x)[keep]  # In unit order: numpy assigns repeated indices in order.
    for name, v in values.items():
        layers[name].reshape(-1)[flat] = v[unit]
    count = np.bincount(flat, minlength=size * size).reshape(size, size).astype(np.int32)
    for name, (multiplier, cap) in DENSITY.items():
        if name in layers:
            layers[name] += np.minimum(count * multiplier, cap)


def observe(table: UnitTable, points: np.ndarray, game_loop: int, player_id: int,
            camera: tuple[float, float], selected: np.ndarray, view: View) -> dict:
    """The player's observation at `game_loop`.

    Args:
      table: the replay's units (`unit_table`).
      points: float32 [U, 2], each unit's estimated world point at `game_loop`.
      game_loop: when.
      player_id: whose view (1-based).
      camera: the player's camera centre (world x, y).
      selected: bool [U], the player's selected units.
      view: the map's size, the resolutions and the fog setting.

    Returns:
      {"feature_screen": int32 [27, S, S], "feature_minimap": int32 [11, M, M],
       "player": int32 [11]}.
    """
    alive = table.alive(game_loop)
    owners = table.owners_at(game_loop)
    types = table.types_at(game_loop)
    types = np.where(types < UNIT_TYPE_SCALE, types, 0)  # Types newer than PySC2 v4's: 0.
    mine = alive & (owners == player_id)
    minimap = Minimap((view.minimap_size,) * 2, view.map_size)
    screen = Camera((view.screen_size,) * 2)
    center = np.asarray(camera, np.float32)
    mxs, mys = minimap.pixel_centers()
    sxs, sys_ = screen.pixel_centers(center)
    eyes = points[mine]
    seen_minimap = _visible(eyes, mxs, mys)
    seen_screen = _visible(eyes, sxs, sys_)
    # Units drawn: the player's, neutral, and enemies in sight (or all of them).
    enemy = alive & (owners != player_id) & (owners != 0)
    if not view.full_information:
        seen = np.zeros_like(enemy)
        candidates = np.flatnonzero(enemy)
        if len(eyes) and len(candidates):
            dx = points[candidates, 0:1] - eyes[None, :, 0]
            dy = points[candidates, 1:2] - eyes[None, :, 1]
            seen[candidates] = (dx * dx + dy * dy <= SIGHT * SIGHT).any(-1)
        enemy &= seen
    shown = mine | (alive & (owners == 0)) | enemy
    order = np.flatnonzero(shown)
    relative = np.where(owners == player_id, _SELF, np.where(owners == 0, _NEUTRAL, _ENEMY))
    player_ids = np.where(owners == 0, NEUTRAL, owners)
    values = {"player_id": player_ids[order], "player_relative": relative[order],
              "unit_type": types[order], "selected": selected[order].astype(np.int32)}

    mini = {name: np.zeros((view.minimap_size,) * 2, np.int32) for name in values}
    _paint(mini, minimap.world_to_pixel(points[order]),
           UNIT_RADIUS * minimap.pixels_per_unit, values, view.minimap_size)
    feature_minimap = np.zeros((len(MINIMAP_FEATURES), *(view.minimap_size,) * 2), np.int32)
    for name, layer in mini.items():
        feature_minimap[getattr(MINIMAP_FEATURES, name).index] = layer
    feature_minimap[MINIMAP_FEATURES.visibility_map.index] = seen_minimap * 2
    half = screen.view_half_extent()
    camera_box = ((np.abs(mxs[None, :] - center[0]) <= half[0])
                  & (np.abs(mys[:, None] - center[1]) <= half[1]))
    feature_minimap[MINIMAP_FEATURES.camera.index] = camera_box

    # A structure under construction: the share of its build time (from its placement to
    # its completion, a constant of its type) that has passed, in percent.
    building = alive & (table.done > game_loop) & (table.done != NEVER)
    span = np.maximum(table.done - table.born, 1)
    progress = np.where(building, (game_loop - table.born) * 100 // span, 0)
    scr = {name: np.zeros((view.screen_size,) * 2, np.int32)
           for name in (*values, "build_progress", *DENSITY)}
    _paint(scr, screen.world_to_pixel(center, points[order]),
           UNIT_RADIUS * screen.pixels_per_unit,
           {**values, "build_progress": progress[order]}, view.screen_size)
    feature_screen = np.zeros((len(SCREEN_FEATURES), *(view.screen_size,) * 2), np.int32)
    for name, layer in scr.items():
        feature_screen[getattr(SCREEN_FEATURES, name).index] = layer
    feature_screen[SCREEN_FEATURES.visibility_map.index] = seen_screen * 2
    return {"feature_screen": feature_screen, "feature_minimap": feature_minimap,
            "player": player_vector(table, game_loop, player_id)}


def player_vector(table: UnitTable, game_loop: int, player_id: int) -> np.ndarray:
    """int32 [11]: PySC2's `player` from the latest PlayerStats event at or before
    `game_loop` (zeros before the first; idle workers, army, warp gates and larvae are not
    in PlayerStats and stay 0)."""
    out = np.zeros(len(Player), np.int32)
    out[Player.player_id] = player_id
    loops, values = table.stats.get(player_id, (np.zeros(0, np.int32), None))
    i = np.searchsorted(loops, game_loop, side="right") - 1
    if i < 0:
        return out
    row = dict(zip(table.stat_names, values[i]))
    workers = row.get("m_scoreValueWorkersActiveCount", 0)
    out[Player.minerals] = row.get("m_scoreValueMineralsCurrent", 0)
    out[Player.vespene] = row.get("m_scoreValueVespeneCurrent", 0)
    out[Player.food_used] = row.get("m_scoreValueFoodUsed", 0) // 4096
    out[Player.food_cap] = row.get("m_scoreValueFoodMade", 0) // 4096
    out[Player.food_workers] = workers
    out[Player.food_army] = max(0, out[Player.food_used] - workers)
    return out


def unit_points(table: UnitTable, known: UnitPoints, game_loop: int) -> np.ndarray:
    """float32 [U, 2]: each unit's point at `game_loop`: its known one (`known`, by tag
    index, for the unit that holds the index then), else where it was born or placed."""
    points = np.stack([table.x, table.y], axis=-1)
    if len(known.index):
        alive = np.flatnonzero(table.alive(game_loop))
        rows = dict(zip(unit_index(table.tag[alive]).tolist(), alive.tolist()))
        hit = [(rows[i], n) for n, i in enumerate(known.index.tolist()) if i in rows]
        if hit:
            r, n = np.asarray(hit).T
            points[r] = known.xy[n]
    return points


def observe_step(table: UnitTable, labels: ActionLabels, t: int, player_id: int,
                 view: View) -> dict:
    """`observe` at agent step t of a player labelled by `label_players`: the units' known
    points, the camera and the selection at the step's first game loop."""
    loop = labels.steps[t].game_loop
    selected = np.isin(table.tag, np.asarray(labels.selections[t], np.int64))
    return observe(table, unit_points(table, labels.unit_points[t], loop), loop, player_id,
                   tuple(labels.cameras[t]), selected, view)
