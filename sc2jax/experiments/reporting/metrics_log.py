"""Training-run logs: a resumable CSV of scalar rows; `Progress` (from `progress`) re-exported.

    log = CsvLog("runs/a3c/metrics.csv", resume_step=checkpoint_step)  # None: a new file.
    progress = Progress(total_steps)
    ...
    log.write({"step": step, "loss": loss, "score_mean": score_mean})
    progress.update(step, {"score_mean": score_mean, "score_max": score_max})
    ...
    progress.close()
    log.close()
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Mapping, Sequence

import numpy as np

from sc2jax.atomic import atomic_write
from sc2jax.experiments.reporting.progress import Progress

__all__ = ["CsvLog", "Progress", "read_csv"]


def _read_complete(path: str) -> tuple[list[str] | None, list[list[str]]]:
    """The header and rows of a CSV file, ignoring a last line cut short (no newline)."""
    with open(path, newline="") as f:
        text = f.read()
    text = text[:text.rfind("\n") + 1]  # Drops a line truncated by a crash mid-write.
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        return None, []
    header = rows[0]
    for number, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise ValueError(f"Line {number} of {path!r} has {len(row)} cells, expected "
                             f"{len(header)} (the header {header}).")
    return header, rows[1:]


def read_csv(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """The columns of a CSV written by `CsvLog`, as float64 arrays (empty cells are NaN).

    A truncated last line (a run still writing, or one that crashed) is ignored.

    Raises:
      ValueError: if the file has no header or a cell is not a number.
    """
    path = os.fspath(path)
    header, rows = _read_complete(path)
    if header is None:
        raise ValueError(f"{path!r} has no CSV header.")
    try:
        values = [[float(cell) if cell else math.nan for cell in row] for row in rows]
    except ValueError as e:
        raise ValueError(f"{path!r} has a cell that is not a number: {e}") from e
    table = np.array(values, dtype=np.float64).reshape(len(rows), len(header))
    return {name: table[:, i] for i, name in enumerate(header)}


def _cell(key: str, value) -> str:
    if value is None:
        return ""
    if isinstance(value, (bool, int, np.integer)):
        return str(int(value))
    try:
        return repr(float(value))  # Round-trips exactly; "nan" and "inf" read back.
    except (TypeError, ValueError) as e:
        raise TypeError(f"Value of {key!r} must be a real number or None, got {value!r}.") from e


class CsvLog:
    """Appends rows of scalars to a CSV file, each row flushed as soon as it is written.

    The header is `fieldnames`, or else the keys of the first row. Later rows may use only
    those keys; a missing key (or a None value) leaves its cell empty.

    Without `resume_step` the file is started afresh (an existing one is replaced). With
    `resume_step` and an existing file, the run continues from a checkpoint taken at step
    `resume_step`: the header is kept, a truncated last line (a crash mid-write) is dropped,
    and so is every row whose `step` cell is greater than `resume_step`, since training
    will log those steps again; rows with an empty `step` cell are kept. The cleaned file is
    written atomically before appending resumes. With `resume_step` and no file (or an
    empty one) the log starts afresh.

    Args:
      path: the CSV file; its directory must exist.
      fieldnames: the column names; None takes them from the first row.
      resume_step: the step of the checkpoint being resumed, or None for a new run.

    Raises:
      ValueError: if `fieldnames` is empty or has duplicates, or, when resuming, if the
        file's header differs from `fieldnames`, lacks a `step` column, or a `step` cell is
        not a number.
    """

    def __init__(self, path: str | os.PathLike, fieldnames: Sequence[str] | None = None,
                 resume_step: int | None = None):
        self.path = os.fspath(path)
        self.fieldnames = None if fieldnames is None else _checked(list(fieldnames))
        header, rows = (None, [])
        if resume_step is not None and os.path.exists(self.path):
            header, rows = _read_complete(self.path)
        if header is None:
            self._file = open(self.path, "w", newline="")  # Closed by close().
            self._writer = csv.writer(self._file, lineterminator="\n")
            if self.fieldnames is not None:
                self._writer.writerow(self.fieldnames)
                self._file.flush()
            return
        if self.fieldnames is not None and header != self.fieldnames:
            raise ValueError(f"Header {header} of {self.path!r} differs from fieldnames "
                             f"{self.fieldnames}.")
        if "step" not in header:
            raise ValueError(f"Cannot resume {self.path!r}: its header {header} has no 'step'.")
        column = header.index("step")
        try:
            kept = [row for row in rows if not row[column] or float(row[column]) <= resume_step]
        except ValueError as e:
            raise ValueError(f"{self.path!r} has a 'step' cell that is not a number: {e}") from e
        with atomic_write(self.path, newline="") as f:
            csv.writer(f, lineterminator="\n").writerows([header, *kept])
        self.fieldnames = header
        self._file = open(self.path, "a", newline="")  # Closed by close().
        self._writer = csv.writer(self._file, lineterminator="\n")

    def write(self, row: Mapping[str, float | int | None]) -> None:
        """Appends one row and flushes it.

        Args:
          row: column name -> value (an int, a real number or None for an empty cell).

        Raises:
          ValueError: if the log is closed, `row` has keys outside the header (named in the
            message), or it is the first row and is empty.
          TypeError: if a value is not a real number or None.
        """
        if self._file.closed:
            raise ValueError(f"CsvLog for {self.path!r} is closed.")
        if self.fieldnames is None:
            self.fieldnames = _checked(list(row))
            self._writer.writerow(self.fieldnames)
        extra = [key for key in row if key not in self.fieldnames]
        if extra:
            raise ValueError(f"Keys {extra} are not columns of {self.path!r}; allowed: "
                             f"{self.fieldnames}.")
        self._writer.writerow([_cell(key, row.get(key)) for key in self.fieldnames])
        self._file.flush()

    def close(self) -> None:
        """Closes the file (closing twice is harmless)."""
        self._file.close()

    def __enter__(self) -> CsvLog:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()


def _checked(fieldnames: list[str]) -> list[str]:
    if not fieldnames:
        raise ValueError("A CSV log needs at least one column, got none.")
    if len(set(fieldnames)) != len(fieldnames):
        raise ValueError(f"Column names must be unique, got {fieldnames}.")
    for name in fieldnames:
        if not isinstance(name, str) or not name or "\n" in name or "\r" in name:
            raise ValueError(f"Column names must be non-empty one-line strings, got {name!r}.")
    return fieldnames

