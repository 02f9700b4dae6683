"""Feature-layer rendering: the screen and minimap layers of PySC2 v4 from the state.

A unit covers every pixel whose centre lies within its radius, and always the pixel that
contains its centre. Where units overlap, the one drawn on top (ground units over
structures over resources over beacons, then the higher slot) gives the categorical and
per-unit values; `unit_density` counts all of them. Only the layers the observation
format asks for are computed.
"""

from __future__ import annotations

from collections.abc import Callable

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.features import PlayerRelative, Visibility
from sc2jax.environment.geometry import Camera, MapGeometry, Minimap, cell_lookup
from sc2jax.environment.specs import ObservationFormat
from sc2jax.environment.state import EnvState, Owner, Units
from sc2jax.environment.units import UNIT_DATA, UnitType

# Drawing order: higher layers are drawn over lower ones.
_RENDER_LAYER = np.zeros(len(UnitType), np.int32)
_RENDER_LAYER[[UnitType.MINERAL_SHARD, UnitType.MINERAL_FIELD, UnitType.VESPENE_GEYSER]] = 1
_RENDER_LAYER[[UnitType.COMMAND_CENTER, UnitType.SUPPLY_DEPOT, UnitType.BARRACKS,
               UnitType.REFINERY]] = 2
_RENDER_LAYER[[UnitType.MARINE, UnitType.ZERGLING, UnitType.ROACH, UnitType.BANELING,
               UnitType.SCV]] = 3

_PLAYER_RELATIVE = {Owner.SELF: PlayerRelative.SELF, Owner.ENEMY: PlayerRelative.ENEMY,
                    Owner.NEUTRAL: PlayerRelative.NEUTRAL}


def player_relative(owner):
    """int32[N] `PlayerRelative` of each owner."""
    out = jnp.zeros_like(owner)
    for o, rel in _PLAYER_RELATIVE.items():
        out = jnp.where(owner == o, int(rel), out)
    return out


def ratio_255(value, maximum):
    """int32: value / maximum mapped to 0..255 (0 where maximum is 0)."""
    return jnp.where(maximum > 0, (value / jnp.maximum(maximum, 1e-6) * 255), 0).astype(jnp.int32)


def coverage(pixel_pos, pixel_radius, size, shown):
    """Which units cover which pixels.

    Args:
      pixel_pos: float32[N, 2] continuous pixel coordinates (x, y) of unit centres.
      pixel_radius: float32[N] radii in pixels.
      size: (width, height) in pixels.
      shown: bool[N] units that may be drawn.

    Returns:
      bool[N, height, width].
    """
    w, h = size
    cols = jnp.arange(w, dtype=jnp.float32) + 0.5
    rows = jnp.arange(h, dtype=jnp.float32) + 0.5
    dx = cols[None, :] - pixel_pos[:, 0:1]
    dy = rows[None, :] - pixel_pos[:, 1:2]
    r2 = (pixel_radius * pixel_radius)[:, None, None]
    inside = dy[:, :, None] ** 2 + dx[:, None, :] ** 2 <= r2
    cx = jnp.floor(pixel_pos[:, 0]).astype(jnp.int32)
    cy = jnp.floor(pixel_pos[:, 1]).astype(jnp.int32)
    at_centre = ((jnp.arange(h)[None, :] == cy[:, None])[:, :, None]
                 & (jnp.arange(w)[None, :] == cx[:, None])[:, None, :])
    return (inside | at_centre) & shown[:, None, None]


def top_unit(cover, units: Units):
    """int32[H, W]: the slot drawn on top at each pixel, or -1."""
    n = units.num_slots
    rank = jnp.asarray(_RENDER_LAYER)[units.type] * n + jnp.arange(n)
    best = jnp.max(jnp.where(cover, rank[:, None, None], -1), axis=0)
    return jnp.where(best >= 0, best % n, -1)


def pick_unit(units: Units, shown, pixel_pos, pixel_radius, pixel):
    """The slot drawn on top at one pixel (int32[2] x, y), or -1: what a click selects."""
    dx = pixel[0].astype(jnp.float32) + 0.5 - pixel_pos[:, 0]
    dy = pixel[1].astype(jnp.float32) + 0.5 - pixel_pos[:, 1]
    inside = dx * dx + dy * dy <= pixel_radius * pixel_radius
    at_centre = ((jnp.floor(pixel_pos[:, 0]).astype(jnp.int32) == pixel[0])
                 & (jnp.floor(pixel_pos[:, 1]).astype(jnp.int32) == pixel[1]))
    cover = (inside | at_centre) & shown
    n = units.num_slots
    rank = jnp.asarray(_RENDER_LAYER)[units.type] * n + jnp.arange(n)
    best = jnp.max(jnp.where(cover, rank, -1))
    return jnp.where(best >= 0, best % n, -1)


def _gather(top, values, background=0):
    return jnp.where(top >= 0, values[jnp.maximum(top, 0)], background).astype(jnp.int32)


class Renderer:
    """Renders the layers an `ObservationFormat` asks for, for one map.

    Args:
      fmt: the observation format (resolutions and layer subsets).
      geometry: the map's static layout.
      fog: whether the map has fog of war (else the playable area is revealed).
      cheat_layers: fill the minimap `unit_type` layer (PySC2's `allow_cheating_layers`).
    """

    def __init__(self, fmt: ObservationFormat, geometry: MapGeometry, fog: bool,
                 cheat_layers: bool = False):
        self.fmt = fmt
        self.geometry = geometry
        self.fog = fog
        self.cheat_layers = cheat_layers
        self.camera = Camera(fmt.screen_size)
        self.minimap = Minimap(fmt.minimap_size, geometry)

    # Per-unit visibility and attributes.

    def units_shown(self, state: EnvState):
        """bool[N]: units the player can see (own units always; others when visible)."""
        units = state.units
        own = units.owner == Owner.SELF
        if not self.fog:
            return units.alive
        seen = self.visible_points(state, units.pos)
        return units.alive & (own | seen)

    def visible_points(self, state: EnvState, xy):
        """bool[...]: world points within sight of one of the player's units."""
        units = state.units
        sight = jnp.asarray(UNIT_DATA.sight)[units.type]
        eyes = units.alive & (units.owner == Owner.SELF)
        d2 = jnp.sum((xy[..., None, :] - units.pos) ** 2, axis=-1)
        return jnp.any(eyes & (d2 <= sight * sight), axis=-1)

    def _visibility(self, state: EnvState, xs, ys):
        """int32[H, W] visibility of world columns xs and rows ys."""
        x0, y0, x1, y1 = self.geometry.playable
        in_play = ((ys >= y0) & (ys < y1))[:, None] & ((xs >= x0) & (xs < x1))[None, :]
        if not self.fog:
            return jnp.where(in_play, int(Visibility.VISIBLE), int(Visibility.HIDDEN))
        units = state.units
        sight = jnp.asarray(UNIT_DATA.sight)[units.type]
        eyes = units.alive & (units.owner == Owner.SELF)
        d2 = ((ys[None, :, None] - units.pos[:, 1, None, None]) ** 2
              + (xs[None, None, :] - units.pos[:, 0, None, None]) ** 2)
        visible = jnp.any(eyes[:, None, None] & (d2 <= (sight * sight)[:, None, None]), axis=0)
        explored = cell_lookup(state.explored, self.geometry.size[1], xs, ys, False)
        out = jnp.where(visible, int(Visibility.VISIBLE),
                        jnp.where(explored, int(Visibility.SEEN), int(Visibility.HIDDEN)))
        return jnp.where(in_play, out, int(Visibility.HIDDEN)).astype(jnp.int32)

    def _terrain(self, grid, xs, ys):
        return cell_lookup(grid, self.geometry.size[1], xs, ys, 0).astype(jnp.int32)

    def screen(self, state: EnvState):
        """int32[len(screen_layers), H, W]."""
        units = state.units
        center = state.camera
        xs, ys = self.camera.pixel_centers(center)
        shown = self.units_shown(state)
        pixel_pos = self.camera.world_to_pixel(center, units.pos)
        radius = jnp.asarray(UNIT_DATA.radius)[units.type] * self.camera.pixels_per_unit
        cache = {}

        def cover():
            if "cover" not in cache:
                cache["cover"] = coverage(pixel_pos, radius, self.camera.size, shown)
            return cache["cover"]

        def top():
            if "top" not in cache:
                cache["top"] = top_unit(cover(), units)
            return cache["top"]

        def density():
            return jnp.sum(cover(), axis=0, dtype=jnp.int32)

        per_unit = self._unit_values(units)
        zeros = lambda: jnp.zeros(self.camera.size[::-1], jnp.int32)  # noqa: E731
        g = self.geometry
        layers: dict[str, Callable[[], jnp.ndarray]] = {
            "height_map": lambda: self._terrain(g.height_map, xs, ys),
            "visibility_map": lambda: self._visibility(state, xs, ys),
            "pathable": lambda: self._terrain(g.pathable, xs, ys),
            "buildable": lambda: self._terrain(g.buildable, xs, ys),
            "unit_density": lambda: jnp.minimum(density(), 15),
            "unit_density_aa": lambda: jnp.minimum(density() * 16, 255),
        }
        for name, values in per_unit.items():
            layers[name] = lambda v=values: _gather(top(), v())
        out = [layers.get(f.name, zeros)() for f in self.fmt.screen_layers]
        return jnp.stack(out).astype(jnp.int32)

    def minimap_layers(self, state: EnvState):
        """int32[len(minimap_layers), H, W]."""
        units = state.units
        xs, ys = self.minimap.pixel_centers()
        shown = self.units_shown(state)
        pixel_pos = self.minimap.world_to_pixel(units.pos)
        radius = jnp.asarray(UNIT_DATA.radius)[units.type] * self.minimap.pixels_per_unit
        cache = {}

        def top():
            if "top" not in cache:
                cache["top"] = top_unit(coverage(pixel_pos, radius, self.minimap.size, shown),
                                        units)
            return cache["top"]

        per_unit = self._unit_values(units)
        zeros = lambda: jnp.zeros(self.minimap.size[::-1], jnp.int32)  # noqa: E731
        g = self.geometry
        layers = {
            "height_map": lambda: self._terrain(g.height_map, xs, ys),
            "visibility_map": lambda: self._visibility(state, xs, ys),
            "camera": lambda: self._camera_layer(state.camera, xs, ys),
            "player_id": lambda: _gather(top(), per_unit["player_id"]()),
            "player_relative": lambda: _gather(top(), per_unit["player_relative"]()),
            "selected": lambda: _gather(top(), per_unit["selected"]()),
            "pathable": lambda: self._terrain(g.pathable, xs, ys),
            "buildable": lambda: self._terrain(g.buildable, xs, ys),
        }
        if self.cheat_layers:
            layers["unit_type"] = lambda: _gather(top(), per_unit["unit_type"]())
        out = [layers.get(f.name, zeros)() for f in self.fmt.minimap_layers]
        return jnp.stack(out).astype(jnp.int32)

    def _camera_layer(self, center, xs, ys):
        hx, hy = self.camera.view_half_extent()
        in_x = (xs >= center[0] - hx) & (xs < center[0] + hx)
        in_y = (ys > center[1] - hy) & (ys <= center[1] + hy)
        return (in_y[:, None] & in_x[None, :]).astype(jnp.int32)

    @staticmethod
    def _unit_values(units: Units) -> dict[str, Callable[[], jnp.ndarray]]:
        """Lazily computed int32[N] per-unit values of the per-unit screen layers."""
        d = UNIT_DATA
        t = units.type
        return {
            "player_id": lambda: units.owner,
            "player_relative": lambda: player_relative(units.owner),
            "unit_type": lambda: jnp.asarray(d.sc2_id)[t],
            "selected": lambda: units.selected.astype(jnp.int32),
            "unit_hit_points": lambda: jnp.ceil(units.health).astype(jnp.int32),
            "unit_hit_points_ratio": lambda: ratio_255(units.health, jnp.asarray(d.max_health)[t]),
            "unit_energy": lambda: units.energy.astype(jnp.int32),
            "unit_energy_ratio": lambda: ratio_255(units.energy, jnp.asarray(d.max_energy)[t]),
            "unit_shields": lambda: units.shields.astype(jnp.int32),
            "unit_shields_ratio": lambda: ratio_255(units.shields, jnp.asarray(d.max_shields)[t]),
        }
