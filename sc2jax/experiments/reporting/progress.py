"""A console progress reporter for training runs: bar, steps/s, ETA and a few metrics.

    with Progress(total_steps) as progress:
        for step, metrics in training:
            progress.update(step, {"score_mean": metrics.score_mean})
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from typing import TextIO


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    minutes, secs = divmod(int(seconds), 60)
    return f"{minutes // 60}:{minutes % 60:02d}:{secs:02d}"


class Progress:
    """Reports training progress: percentage, steps done/total, steps/s, ETA and metrics.

    On a TTY the line is redrawn in place (with a bar); otherwise (a log file, CI) plain
    lines are printed. Either way at most one output per `min_interval_s`, except that the
    first update and the one reaching `total_steps` are always shown. Steps/s is measured
    between consecutive updates (so time before the first update, e.g. compilation, is
    excluded) and smoothed by an exponential moving average.

    Args:
      total_steps: the step at which training ends (> 0).
      stream: where to write; None means `sys.stderr` (looked up at construction).
      min_interval_s: the least time between outputs; None picks 0.1 s on a TTY, else 30 s.
      show: the metric names to display, in order; None displays every metric given.
      smoothing: the moving-average weight of the newest rate, in (0, 1] (1: no smoothing).
      clock: a monotonic clock in seconds (tests pass a fake one).

    Raises:
      ValueError: if `total_steps`, `min_interval_s` or `smoothing` is out of range.
    """

    def __init__(self, total_steps: int, *, stream: TextIO | None = None,
                 min_interval_s: float | None = None, show: Sequence[str] | None = None,
                 smoothing: float = 0.3, clock: Callable[[], float] = time.monotonic):
        if total_steps <= 0:
            raise ValueError(f"total_steps must be positive, got {total_steps}.")
        if min_interval_s is not None and min_interval_s < 0:
            raise ValueError(f"min_interval_s must be >= 0, got {min_interval_s}.")
        if not 0 < smoothing <= 1:
            raise ValueError(f"smoothing must be in (0, 1], got {smoothing}.")
        self.total_steps, self.show, self.smoothing = total_steps, show, smoothing
        self._stream = sys.stderr if stream is None else stream
        try:
            self._tty = bool(self._stream.isatty())
        except (AttributeError, ValueError):
            self._tty = False
        default_interval = 0.1 if self._tty else 30.0
        self.min_interval_s = default_interval if min_interval_s is None else min_interval_s
        self._clock, self._start = clock, clock()
        self._last: tuple[int, float] | None = None  # (step, time) of the last update.
        self._rate: float | None = None
        self._printed_at = -math.inf
        self._pending: str | None = None  # The newest line not yet shown.
        self._width = 0  # Length of the line drawn on a TTY.

    @property
    def steps_per_second(self) -> float | None:
        """The smoothed rate, or None before two updates."""
        return self._rate

    def update(self, step: int, metrics: Mapping[str, float] | None = None) -> None:
        """Records that training reached `step`, and shows the line if it is due.

        Args:
          step: the current training step (e.g. agent steps so far).
          metrics: scalars to display (filtered and ordered by `show`); NaN shows "nan".
        """
        now = self._clock()
        if self._last is not None and now > self._last[1]:
            rate = (step - self._last[0]) / (now - self._last[1])
            self._rate = rate if self._rate is None else (
                self.smoothing * rate + (1 - self.smoothing) * self._rate)
        first, self._last = self._last is None, (step, now)
        self._pending = self._line(step, metrics or {}, now)
        if first or step >= self.total_steps or now - self._printed_at >= self.min_interval_s:
            self._emit(now)

    def close(self) -> None:
        """Shows the newest line if it was held back, and ends the TTY line."""
        if self._pending is not None:
            self._emit(self._clock())
        if self._tty and self._width:
            self._stream.write("\n")
            self._stream.flush()
            self._width = 0

    def _line(self, step: int, metrics: Mapping[str, float], now: float) -> str:
        fraction = min(max(step / self.total_steps, 0.0), 1.0)
        rate = self._rate
        eta = (self.total_steps - step) / rate if rate else math.inf
        parts = [f"{100 * fraction:5.1f}%", f"{step:,}/{self.total_steps:,} steps",
                 "? steps/s" if rate is None else f"{rate:,.{1 if rate < 100 else 0}f} steps/s",
                 f"ETA {_duration(max(eta, 0.0))}", f"elapsed {_duration(now - self._start)}"]
        names = [name for name in (metrics if self.show is None else self.show) if name in metrics]
        if names:
            parts.append(" ".join(f"{name}={float(metrics[name]):.4g}" for name in names))
        if self._tty:
            filled = int(round(20 * fraction))
            parts[0] = f"[{'#' * filled}{'.' * (20 - filled)}] {parts[0]}"
        return " | ".join(parts)

    def _emit(self, now: float) -> None:
        line, self._pending, self._printed_at = self._pending, None, now
        if self._tty:
            self._stream.write(f"\r{line}{' ' * max(self._width - len(line), 0)}")
            self._width = len(line)
        else:
            self._stream.write(line + "\n")
        self._stream.flush()

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()
