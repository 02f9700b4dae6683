"""Map geometry and PySC2's coordinate transforms.

World coordinates have their origin at the bottom-left, y up. Feature layers are indexed
(y, x) from the top-left. The screen is centred on the camera and spans
`CAMERA_WIDTH` world units along its longer side (PySC2's `camera_width_world_units`);
the minimap spans the whole map at `minimap_max_dim / map_max_dim` pixels per unit.
A pixel stands for the world point at its centre.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.fusion import materialize

CAMERA_WIDTH = 24.0


@dataclasses.dataclass(frozen=True, eq=False)
class MapGeometry:
    """A map's static layout.

    Attributes:
      size: (width, height) in world units (cells).
      playable: (x0, y0, x1, y1), the playable area.
      camera_bounds: (x0, y0, x1, y1), where the camera centre may go.
      height_map: uint8[height, width], the `height_map` layer value of each cell, row 0
        at the top (y = height - 1).
      pathable: bool[height, width], row 0 at the top.
      buildable: bool[height, width], row 0 at the top.
    """

    size: tuple[int, int]
    playable: tuple[float, float, float, float]
    camera_bounds: tuple[float, float, float, float]
    height_map: np.ndarray
    pathable: np.ndarray
    buildable: np.ndarray

    @property
    def max_dim(self) -> int:
        return max(self.size)


def array_module(*arrays):
    """numpy if every array is a numpy array (the SC2-API client's host work on the
    game's units), else jax.numpy (the simulator, traced or not)."""
    return np if all(isinstance(a, np.ndarray) for a in arrays) else jnp


def squared_length(v):
    """float32[...]: the squared lengths of vectors v (float32[..., 2]), as x² + y².

    Elementwise on purpose: XLA's CPU backend hands a sum over a size-2 axis
    (`sum(v * v, axis=-1)`) to a library reduction several times slower than the fused
    arithmetic, and the engine's pair arrays ([N, N, 2]) make that its largest cost.
    """
    return v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1]


def distances(pos, to, eps=1e-12):
    """float32[N, M]: centre distances sqrt(|pos[i] - to[j]|² + eps) (pos float32[N, 2],
    to float32[M, 2]): the engine's pair distance."""
    return jnp.sqrt(squared_length(pos[:, None, :] - to[None, :, :]) + eps)


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
        """Returns (xs float32[sx], ys float32[sy]): world x of each column, y of each row."""
        sx, sy = self.size
        xs = center[0] + (jnp.arange(sx, dtype=jnp.float32) + 0.5 - sx / 2) / self.pixels_per_unit
        ys = center[1] - (jnp.arange(sy, dtype=jnp.float32) + 0.5 - sy / 2) / self.pixels_per_unit
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


def clamp_camera(geometry: MapGeometry, center):
    """Clamps a camera centre to the map's camera bounds."""
    x0, y0, x1, y1 = geometry.camera_bounds
    return jnp.clip(center, jnp.array([x0, y0], jnp.float32), jnp.array([x1, y1], jnp.float32))


MAX_ROW_PATTERNS = 8
"""`cell_lookup` of a fixed grid with at most this many distinct rows goes by its rows'
patterns; of one with more, by a gather."""


def cell_lookup(grid: np.ndarray, map_height: int, xs, ys, fill=0):
    """Samples a [height, width] top-row-first grid at world columns xs and rows ys.

    At traced points, a gather of one cell per pixel is the slow way on XLA's CPU backend
    (a scalar loop: about 2 ns a pixel, 9 us for a 64x64 screen). So a fixed grid with
    few distinct rows (every mini-game's terrain) is looked up by its rows' patterns,
    and a bool grid (the explored cells) by bits packed per row: both gather only one
    value per view row or column, and the rest is elementwise.

    Args:
      grid: the map grid, row 0 at the top (numpy: fixed; or traced).
      map_height: the map height in cells.
      xs: float32[W] world x per output column.
      ys: float32[H] world y per output row (xs and ys both numpy: the lookup is
        made while tracing, `_static_cell_lookup`).
      fill: the value outside the map.

    Returns:
      [H, W] grid values (numpy where grid, xs and ys all are).
    """
    h, w = grid.shape
    static = isinstance(xs, np.ndarray) and isinstance(ys, np.ndarray)
    xp = np if static else jnp
    cx = xp.floor(xs).astype(np.int32)
    cy = (map_height - 1 - xp.floor(ys)).astype(np.int32)
    if static:
        return _static_cell_lookup(grid, cx, cy, fill)
    # Column and row cells, -1 outside the map: computed once, not per pixel.
    cx = materialize(jnp.where((cx >= 0) & (cx < w), cx, -1))
    cy = materialize(jnp.where((cy >= 0) & (cy < h), cy, -1))
    inside = (cy >= 0)[:, None] & (cx >= 0)[None, :]
    cx, cy = jnp.maximum(cx, 0), jnp.maximum(cy, 0)
    patterns = None
    if isinstance(grid, np.ndarray):
        patterns, pattern_of_row = np.unique(grid, axis=0, return_inverse=True)
    if patterns is not None and len(patterns) <= MAX_ROW_PATTERNS:
        values = _lookup_by_row_patterns(patterns, pattern_of_row.reshape(-1), cx, cy)
    elif grid.dtype == bool:
        values = _lookup_bits(jnp.asarray(grid), cx, cy)
    else:
        values = jnp.asarray(grid)[cy[:, None], cx[None, :]]
    return jnp.where(inside, values, jnp.asarray(fill, values.dtype))


def _lookup_by_row_patterns(patterns: np.ndarray, pattern_of_row: np.ndarray, cx, cy):
    """[H, W] grid[cy[i], cx[j]] of a fixed grid given as its distinct rows (`patterns`,
    [P, w]) and each row's pattern (int[h]): the columns of each pattern (P gathers of
    W), chosen per view row by its pattern (one gather of H)."""
    row_pattern = materialize(jnp.asarray(pattern_of_row, jnp.int32)[cy])  # [H]
    values = None
    for k, pattern in enumerate(patterns):
        columns = materialize(jnp.asarray(pattern)[cx])[None, :]  # [1, W]
        values = columns if values is None else jnp.where((row_pattern == k)[:, None],
                                                          columns, values)
    return jnp.broadcast_to(values, (cy.shape[0], cx.shape[0]))


def _lookup_bits(grid, cx, cy):
    """bool[H, W] grid[cy[i], cx[j]] of a traced bool grid [h, w]: each grid row packed
    into 32-bit words, the view rows' words gathered (H of them per word), and each
    pixel's bit shifted out of its column's word."""
    h, w = grid.shape
    words = -(-w // 32)
    bits = jnp.pad(grid, ((0, 0), (0, words * 32 - w))).reshape(h, words, 32)
    packed = jnp.sum(bits.astype(jnp.uint32) << jnp.arange(32, dtype=jnp.uint32), axis=-1,
                     dtype=jnp.uint32)  # [h, words]: bit b of word k is column 32k + b.
    rows = materialize(packed[cy])  # [H, words]
    word, shift = materialize(cx // 32), materialize((cx % 32).astype(jnp.uint32))
    chosen = rows[:, :1]
    for k in range(1, words):
        chosen = jnp.where((word == k)[None, :], rows[:, k:k + 1], chosen)
    return ((chosen >> shift[None, :]) & 1) == 1


def _static_cell_lookup(grid, cx: np.ndarray, cy: np.ndarray, fill):
    """`cell_lookup` at fixed (numpy) cells cx int32[W] and cy int32[H]: all numpy for a
    numpy grid; for a traced grid, strided slices where the cells are evenly spaced and
    distinct (a minimap of one pixel per cell, or of a whole number of cells per pixel),
    and a gather elsewhere."""
    h, w = grid.shape
    inside = ((cy >= 0) & (cy < h))[:, None] & ((cx >= 0) & (cx < w))[None, :]
    cx, cy = np.clip(cx, 0, w - 1), np.clip(cy, 0, h - 1)
    if isinstance(grid, np.ndarray):
        return np.where(inside, grid[cy[:, None], cx[None, :]], np.asarray(fill, grid.dtype))
    values = _take_static(_take_static(grid, cy, 0), cx, 1)
    return values if inside.all() else jnp.where(inside, values, jnp.asarray(fill, grid.dtype))


def _take_static(x, index: np.ndarray, axis: int):
    """x's entries at fixed indices along `axis`: a strided slice for evenly spaced
    increasing indices, or a gather."""
    step = index[1] - index[0] if len(index) > 1 else 1
    if step > 0 and np.array_equal(index, index[0] + step * np.arange(len(index))):
        return jax.lax.slice_in_dim(x, int(index[0]), int(index[-1]) + 1, int(step), axis)
    return jnp.take(x, index, axis=axis)
