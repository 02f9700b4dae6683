"""Learning-curve figures in the style of Figure 6 of the SC2LE paper (Vinyals et al., 2017).

Every run is drawn as a faint line and the best run as a solid one, with optional labelled
horizontal reference lines (e.g. the paper's scores). matplotlib is imported inside the
plotting function only, with the Agg backend and without pyplot (no global figure state).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping

import numpy as np

from sc2jax.atomic import atomic_write


def smooth(y: np.ndarray, window: int) -> np.ndarray:
    """Trailing moving average over `window` points, ignoring NaNs.

    Point i is the mean of the non-NaN values among y[max(0, i - window + 1) : i + 1]; it
    is NaN if they are all NaN.

    Raises:
      ValueError: if `window` < 1.
    """
    if window < 1:
        raise ValueError(f"Smoothing window must be >= 1, got {window}.")
    y = np.asarray(y, dtype=np.float64)
    valid = ~np.isnan(y)
    sums = np.concatenate([[0.0], np.cumsum(np.where(valid, y, 0.0))])
    counts = np.concatenate([[0], np.cumsum(valid)])
    lo = np.maximum(np.arange(1, y.size + 1) - window, 0)
    n = counts[1:] - counts[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, (sums[1:] - sums[lo]) / np.maximum(n, 1), np.nan)


def final_mean(y: np.ndarray, tail: float) -> float:
    """Mean of the last ceil(tail * len(y)) values of `y` (at least one), ignoring NaNs.

    This ranks runs: the best run is the one with the highest final mean (-inf if the tail
    is all NaN).
    """
    y = np.asarray(y, dtype=np.float64)
    last = y[-max(1, math.ceil(tail * y.size)):]
    last = last[~np.isnan(last)]
    return float(last.mean()) if last.size else -math.inf


def plot_learning_curves(runs: Mapping[str, tuple[np.ndarray, np.ndarray]],
                         path: str | os.PathLike, *, title: str, xlabel: str = "agent steps",
                         ylabel: str = "mean episode score", smoothing: int = 1,
                         tail: float = 0.1, references: Mapping[str, float] | None = None,
                         ) -> str:
    """Plots learning curves of several runs to a PNG, highlighting the best run.

    All runs are drawn faintly, smoothed by `smooth(y, smoothing)`; the run with the
    highest `final_mean(y, tail)` of its raw (unsmoothed) scores, i.e. the mean over the
    last `tail` fraction of its points, is drawn solid and named in the legend. Each
    reference `label: value` is a dashed horizontal line labelled "label (value)".

    The PNG is written atomically: to a temporary file in the same directory (created if
    missing), then renamed over `path`.

    Args:
      runs: run name -> (x, y), 1-D arrays of equal non-zero length (e.g. agent steps and
        mean episode scores).
      path: the PNG file to write.
      title: the figure title (e.g. the mini-game's name).
      xlabel: the x-axis label.
      ylabel: the y-axis label.
      smoothing: moving-average window in points (1: no smoothing).
      tail: fraction of each run's last points whose mean ranks the runs, in (0, 1].
      references: optional label -> finite score drawn as horizontal lines.

    Returns:
      The path written, as a string.

    Raises:
      ValueError: if `runs` is empty, a run's x and y are not 1-D of equal non-zero length,
        `smoothing` < 1, `tail` is outside (0, 1] or a reference is not finite.
    """
    if not runs:
        raise ValueError("runs is empty: there is nothing to plot.")
    if not 0 < tail <= 1:
        raise ValueError(f"tail must be in (0, 1], got {tail}.")
    curves = {}
    for name, (x, y) in runs.items():
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        if x.ndim != 1 or y.ndim != 1 or x.size != y.size or x.size == 0:
            raise ValueError(f"Run {name!r} needs 1-D x and y of equal non-zero length, got "
                             f"shapes {x.shape} and {y.shape}.")
        curves[name] = (x, y, smooth(y, smoothing))
    references = dict(references or {})
    for label, value in references.items():
        if not math.isfinite(value):
            raise ValueError(f"Reference {label!r} must be a finite number, got {value}.")

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4.0), dpi=120)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    best = max(curves, key=lambda name: final_mean(curves[name][1], tail))
    others = [name for name in curves if name != best]
    for i, name in enumerate(others):
        x, _, y_smooth = curves[name]
        ax.plot(x, y_smooth, color="C0", alpha=0.25, linewidth=0.8,
                label=f"other runs ({len(others)})" if i == 0 else None)
    x, y, y_smooth = curves[best]
    ax.plot(x, y_smooth, color="C0", linewidth=2.0,
            label=f"best: {best} (final mean {final_mean(y, tail):.4g})")
    for i, (label, value) in enumerate(references.items()):
        ax.axhline(value, color=f"C{i + 1}", linestyle="--", linewidth=1.0,
                   label=f"{label} ({value:g})")
    ax.set(title=title, xlabel=xlabel, ylabel=ylabel)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    fig.tight_layout()

    path = os.fspath(path)
    with atomic_write(path, "wb") as f:
        fig.savefig(f, format="png")
    return path
