"""Argument checks shared by the experiment modules."""

from __future__ import annotations


def check_positive_int(name: str, value: object) -> None:
    """Raises ValueError naming `name` unless `value` is an int >= 1 (bools are not)."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name} must be a positive int, got {value!r}")
