"""Atomic file writes: a file holds either its old or its new contents, never a part.

    with atomic_write("run/eval.json") as f:
        json.dump(result, f)

The new contents go to a temporary file in the same directory, which is flushed,
fsynced and renamed over the target (`os.replace`, atomic on POSIX); the directory is
then fsynced so that the rename survives a crash. On any error the temporary file is
removed and the target is left untouched.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from typing import IO, Any


def fsync(path: str, directory: bool = False) -> None:
    """Flushes a file (or, with `directory`, a directory's entries) to disk."""
    if directory and not hasattr(os, "O_DIRECTORY"):  # Windows cannot open a directory.
        return
    fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if directory else 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "w", **open_kwargs) -> Iterator[IO]:
    """Yields a file to write; on a clean exit its contents replace `path` at once.

    Args:
      path: the file to write; its directory is created if missing.
      mode: "w" (text) or "wb" (binary).
      **open_kwargs: passed to `open` (e.g. `newline=""` for csv).
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    path = os.path.abspath(os.fspath(path))
    directory = os.path.dirname(path)
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{os.path.basename(path)}.",
                               suffix=".tmp")
    try:
        with os.fdopen(fd, mode, **open_kwargs) as f:
            os.chmod(tmp, 0o644)  # mkstemp makes it readable by its owner only.
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    fsync(directory, directory=True)


def write_json_atomic(path: str | os.PathLike, obj: Any, *, indent: int | None = 1) -> None:
    """Writes `obj` as JSON to `path` so that `path` holds either the old or the new file.

    The JSON goes to a temporary file in the same directory, which is flushed, fsynced
    and renamed over `path` (`os.replace`, atomic on POSIX); the directory is fsynced
    too, so that the rename survives a crash. The temporary file is removed on error.

    Args:
      path: the file to write; its directory is created if missing.
      obj: a JSON-serialisable object.
      indent: passed to `json.dump`.

    Raises:
      TypeError: if `obj` is not JSON-serialisable (`path` is then left untouched).
    """
    with atomic_write(path) as f:
        json.dump(obj, f, indent=indent)
