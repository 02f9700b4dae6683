"""The fog's sight test (`observations._visible_grid`, `_visible_points`) against its
definition, cell by cell: a cell on the map is in sight when its centre lies within
SIGHT of the centre of a cell that holds one of the player's units."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sc2jax.replay_sl.observations import (
    SIGHT,
    _eye_cells,
    _visible_grid,
    _visible_points,
)

MAP = (23, 17)  # Width, height: small, not square.


def _by_definition(points, mine, t, x, y):
    """Whether cell (x, y) at step t is on the map and in sight, by the definition."""
    width, height = MAP
    if not (0 <= x < width and 0 <= y < height):
        return False
    for p in points[t][mine[t]]:
        cx = min(max(int(np.floor(p[0])), 0), width - 1)
        cy = min(max(int(np.floor(p[1])), 0), height - 1)
        if (x - cx) ** 2 + (y - cy) ** 2 <= SIGHT ** 2:
            return True
    return False


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2 ** 31 - 1))
def test_sight_is_its_definition(seed):
    rng = np.random.default_rng(seed)
    steps, units = 3, 5
    # Units on and off the map (an eye off the map sees from its nearest cell).
    points = rng.uniform(-4, 27, (steps, units, 2)).astype(np.float32)
    mine = rng.random((steps, units)) < 0.4
    eyes = _eye_cells(points, mine, MAP)
    # Query cells: rows in any order, columns non-decreasing, some off the map.
    rows = rng.integers(-12, 30, (steps, 6))
    cols = np.sort(rng.integers(-12, 35, (steps, 7)), axis=1)
    grid = _visible_grid(eyes, rows, cols, MAP)
    want = [[[_by_definition(points, mine, t, cols[t, j], rows[t, i]) for j in range(7)]
             for i in range(6)] for t in range(steps)]
    np.testing.assert_array_equal(grid, np.asarray(want, bool))
    t = rng.integers(0, steps, 20)
    xs, ys = rng.uniform(-12, 35, 20), rng.uniform(-12, 30, 20)
    got = _visible_points(eyes, t, xs, ys, MAP)
    want = [_by_definition(points, mine, t[n], int(np.floor(xs[n])), int(np.floor(ys[n])))
            for n in range(20)]
    np.testing.assert_array_equal(got, np.asarray(want, bool))


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2 ** 31 - 1))
def test_sight_of_repeated_rows_and_columns_is_its_definition(seed):
    """A screen's pixels sample each cell two or three times (the repeated cells are
    drawn once and copied)."""
    rng = np.random.default_rng(seed)
    steps, units = 3, 5
    points = rng.uniform(-4, 27, (steps, units, 2)).astype(np.float32)
    mine = rng.random((steps, units)) < 0.5
    eyes = _eye_cells(points, mine, MAP)
    pixels = (np.arange(16) + 0.5) / 2.7  # 16 pixels over 6 cells.
    cols = np.floor(rng.uniform(-8, 25, (steps, 1)) + pixels).astype(np.int64)
    rows = np.floor(rng.uniform(-8, 20, (steps, 1)) - pixels).astype(np.int64)  # y falls.
    grid = _visible_grid(eyes, rows, cols, MAP)
    want = [[[_by_definition(points, mine, t, cols[t, j], rows[t, i]) for j in range(16)]
             for i in range(16)] for t in range(steps)]
    np.testing.assert_array_equal(grid, np.asarray(want, bool))
