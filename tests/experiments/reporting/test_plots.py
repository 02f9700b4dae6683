"""Tests for the learning-curve plot."""

import os

import numpy as np
import pytest

from sc2jax.experiments.reporting import plots

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_smooth_is_a_trailing_mean_ignoring_nan():
    # Window 2: [1], [1, 3], [3, nan], [nan, 5] -> 1, 2, 3, 5.
    np.testing.assert_array_equal(plots.smooth(np.array([1.0, 3.0, np.nan, 5.0]), 2),
                                  [1.0, 2.0, 3.0, 5.0])
    np.testing.assert_array_equal(plots.smooth(np.array([np.nan, 2.0]), 1), [np.nan, 2.0])


def test_final_mean_uses_the_last_tail_fraction():
    y = np.arange(10.0)
    assert plots.final_mean(y, 0.2) == 8.5  # Mean of the last ceil(0.2 * 10) = 2: 8, 9.
    assert plots.final_mean(y, 0.01) == 9.0  # At least one point.
    assert plots.final_mean(np.array([5.0, np.nan]), 0.5) == -np.inf


def test_writes_a_png(tmp_path):
    x = np.linspace(0, 1e6, 50)
    runs = {f"lr={lr}": (x, lr * 1e4 * np.sqrt(x / 1e6) + np.sin(x)) for lr in (1, 2, 3)}
    path = tmp_path / "figures" / "curves.png"
    written = plots.plot_learning_curves(
        runs, path, title="MoveToBeacon", smoothing=5,
        references={"DeepMind human player": 26.0, "FullyConv (paper)": 26.0})
    assert written == str(path)
    assert path.read_bytes()[:8] == PNG_MAGIC
    assert os.listdir(path.parent) == ["curves.png"]  # No temporary file left behind.


@pytest.mark.parametrize("runs, kwargs, match", [
    ({}, {}, "runs is empty"),
    ({"a": (np.arange(3), np.arange(4))}, {}, "equal non-zero length"),
    ({"a": (np.arange(0), np.arange(0))}, {}, "equal non-zero length"),
    ({"a": (np.zeros((2, 2)), np.zeros((2, 2)))}, {}, "1-D"),
    ({"a": (np.arange(3), np.arange(3))}, {"smoothing": 0}, "window must be >= 1"),
    ({"a": (np.arange(3), np.arange(3))}, {"tail": 0.0}, "tail must be in"),
    ({"a": (np.arange(3), np.arange(3))}, {"references": {"paper": np.nan}}, "finite"),
])
def test_bad_input(tmp_path, runs, kwargs, match):
    path = tmp_path / "bad.png"
    with pytest.raises(ValueError, match=match):
        plots.plot_learning_curves(runs, path, title="t", **kwargs)
    assert not path.exists()
