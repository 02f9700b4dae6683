"""Argument checks shared by every package: each raises ValueError naming the value."""

from __future__ import annotations

import os


def check_not_a_file(name: str, path) -> None:
    """Raises ValueError naming `name` if `path` is an existing file: a run directory
    must be a directory, new or a run's."""
    if path and os.path.exists(path) and not os.path.isdir(path):
        raise ValueError(f"{name}={str(path)!r} is a file; give a directory (new or a run's)")


def check_positive_int(name: str, value: object) -> None:
    """Raises ValueError naming `name` unless `value` is an int >= 1 (bools are not)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name} must be a positive int, got {value!r}")


def check_non_negative_int(name: str, value: object) -> None:
    """Raises ValueError naming `name` unless `value` is an int >= 0 (bools are not)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f"{name} must be an int >= 0, got {value!r}")


def positive_ints(name: str, values) -> list[int]:
    """A list flag's strings as positive ints; raises ValueError naming `name` otherwise."""
    return _ints(name, values, 1, "positive integers")


def non_negative_ints(name: str, values) -> list[int]:
    """A list flag's strings as ints >= 0; raises ValueError naming `name` otherwise."""
    return _ints(name, values, 0, "integers >= 0")


def _ints(name: str, values, low: int, allowed: str) -> list[int]:
    try:
        out = [int(v) for v in values]
    except ValueError:
        out = []
    if not out or any(v < low for v in out):
        raise ValueError(f"--{name} must be a comma-separated list of {allowed}, "
                         f"got {','.join(map(str, values))!r}")
    return out


def check_known(kind: str, names, allowed) -> None:
    """Raises ValueError naming the first of `names` not in `allowed`, and what is allowed."""
    for name in names:
        if name not in allowed:
            raise ValueError(f"unknown {kind} {name!r}; allowed: {sorted(allowed)}")
