"""Close matches for a mistyped name, for error messages."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def did_you_mean(value: object, choices: Iterable[str], n: int = 3) -> str:
    """"; did you mean A, B?" with up to `n` choices close to `value`, or "" if none."""
    close = difflib.get_close_matches(str(value), list(choices), n=n)
    return f"; did you mean {', '.join(close)}?" if close else ""
