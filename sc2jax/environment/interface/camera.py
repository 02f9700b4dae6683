"""PySC2's coordinate transforms between the world, the screen and the minimap.

World coordinates have their origin at the bottom-left, y up. Feature layers are indexed
(y, x) from the top-left. The screen is centred on the camera and spans
`CAMERA_WIDTH` world units along its longer side (PySC2's `camera_width_world_units`);
the minimap spans the whole map at `minimap_max_dim / map_max_dim` pixels per unit;
the raw interface's grid (`raw_units`, the raw actions' `world` point) spans it at
`raw_resolution / map_max_dim` along each axis. A pixel stands for the world point at
its centre.

Used by the simulator (under jit) and by the SC2-API client (on numpy arrays of the
game's units), so it imports nothing else of sc2jax.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

CAMERA_WIDTH = 24.0


def array_module(*arrays):
    """numpy if every array is a numpy array (the SC2-API client's host work on the
    game's units), else jax.numpy (the simulator, traced or not)."""
    return np if all(isinstance(a, np.ndarray) for a in arrays) else jnp


def _stack_xy(px, py):
    return array_module(px, py).stack([px, py], axis=-1)


class Camera:
    """Pixel <-> world transforms for a screen of `(sx, sy)` pixels.

    All methods are jittable; `center` is a float32[2] world point.
    """

    def __init__(self, screen_size: tuple[int, int]):
        self.size = screen_size
        self.pixels_per_unit = max(screen_size) / CAMERA_WIDTH

    def world_to_pixel(self, center, xy):
        """float32[..., 2] world -> float32[..., 2] continuous screen pixel coords (x, y).

        Jittable, and also takes numpy arrays (giving the same float32 values).
        """
        sx, sy = self.size
        px = (xy[..., 0] - center[0]) * self.pixels_per_unit + sx / 2
        py = (center[1] - xy[..., 1]) * self.pixels_per_unit + sy / 2
        return _stack_xy(px, py)

    def pixel_to_world(self, center, pixel):
        """int[..., 2] pixel (x, y) -> float32[..., 2] world point at the pixel centre."""
        sx, sy = self.size
        pixel = pixel.astype(jnp.float32) + 0.5
        wx = center[0] + (pixel[..., 0] - sx / 2) / self.pixels_per_unit
        wy = center[1] - (pixel[..., 1] - sy / 2) / self.pixels_per_unit
        return jnp.stack([wx, wy], axis=-1)

    def pixel_centers(self, center):
        """Returns (xs float32[sx], ys float32[sy]): world x of each column, y of each row
        (numpy for a numpy `center`, else jax)."""
        sx, sy = self.size
        xp = array_module(center)
        xs = center[0] + (xp.arange(sx, dtype=xp.float32) + 0.5 - sx / 2) / self.pixels_per_unit
        ys = center[1] - (xp.arange(sy, dtype=xp.float32) + 0.5 - sy / 2) / self.pixels_per_unit
        return xs, ys

    def view_half_extent(self) -> tuple[float, float]:
        """Half the screen's width and height, in world units."""
        sx, sy = self.size
        return sx / 2 / self.pixels_per_unit, sy / 2 / self.pixels_per_unit


class Minimap:
    """Pixel <-> world transforms for a minimap of `(mx, my)` pixels over a whole map of
    `map_size` (width, height) world units."""

    def __init__(self, minimap_size: tuple[int, int], map_size: tuple[int, int]):
        self.size = minimap_size
        self.map_height = map_size[1]
        self.pixels_per_unit = max(minimap_size) / max(map_size)

    def world_to_pixel(self, xy):
        """As `Camera.world_to_pixel` (jittable, or numpy)."""
        px = xy[..., 0] * self.pixels_per_unit
        py = (self.map_height - xy[..., 1]) * self.pixels_per_unit
        return _stack_xy(px, py)

    def pixel_to_world(self, pixel):
        pixel = pixel.astype(jnp.float32) + 0.5
        wx = pixel[..., 0] / self.pixels_per_unit
        wy = self.map_height - pixel[..., 1] / self.pixels_per_unit
        return jnp.stack([wx, wy], axis=-1)

    def pixel_centers(self):
        """Returns (xs float32[mx], ys float32[my]) as numpy: the minimap never moves, so
        what depends on them alone is computed once, while tracing (in float64, so that
        a centre on a cell edge is exactly on it)."""
        mx, my = self.size
        xs = (np.arange(mx) + 0.5) / self.pixels_per_unit
        ys = self.map_height - (np.arange(my) + 0.5) / self.pixels_per_unit
        return xs.astype(np.float32), ys.astype(np.float32)


class RawGrid:
    """Pixel <-> world transforms of PySC2's raw interface: `raw_units` x, y and the raw
    actions' `world` point, on a grid of `resolution` (x, y) over a map of `map_size`
    (width, height) world units, y down from the map's top edge.

    Each axis is scaled by its resolution over the map's longer side, as PySC2 v4 does
    (`Features.init_camera`); its default resolution, the map size, is one pixel a world
    unit on a square map. Radii are scaled by the x axis's factor, as PySC2's.
    """

    def __init__(self, resolution: tuple[int, int], map_size: tuple[int, int]):
        self.size = tuple(int(r) for r in resolution)
        self.map_height = map_size[1]
        longer = max(map_size)
        self.scale = (self.size[0] / longer, self.size[1] / longer)
        self.pixels_per_unit = self.scale[0]

    def world_to_pixel(self, xy):
        """As `Camera.world_to_pixel` (jittable, or numpy)."""
        return _stack_xy(xy[..., 0] * self.scale[0],
                         (self.map_height - xy[..., 1]) * self.scale[1])

    def pixel_to_world(self, pixel):
        """The world point (float32[..., 2]) at the centre of int pixel[..., 2]."""
        pixel = pixel.astype(jnp.float32) + 0.5
        return jnp.stack([pixel[..., 0] / self.scale[0],
                          self.map_height - pixel[..., 1] / self.scale[1]], axis=-1)
