"""Map geometry: a map's static layout, distances, the camera's bounds, cell lookups.

PySC2's pixel <-> world transforms are in `sc2jax.environment.interface.camera`.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.xla.fusion import materialize


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
