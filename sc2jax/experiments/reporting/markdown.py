"""Writing one section of a markdown file (the benchmark scripts' tables)."""

from __future__ import annotations

import os

from sc2jax.atomic import atomic_write


def write_section(path: str, section: str) -> None:
    """Replaces (or appends) a `## ` section of a markdown file, keeping the others.

    The section is named by its own first line (its `## ` heading) and runs to the
    next `## ` heading. Subsections (`### `) under the old section are kept after the
    new text, so hand-written notes survive a rerun. The file is replaced atomically.

    Args:
      path: the markdown file (created with a "# Benchmarks" title if missing).
      section: the new section, starting with its `## ` heading line.

    Raises:
      ValueError: if `section` does not start with a `## ` heading.
    """
    heading = section.split("\n", 1)[0]
    if not heading.startswith("## "):
        raise ValueError(f"section must start with a '## ' heading, got {heading!r}")
    text = open(path).read() if os.path.exists(path) else "# Benchmarks\n"
    start = text.find(heading)
    if start < 0:
        text = text.rstrip("\n") + "\n\n" + section
    else:
        end = text.find("\n## ", start + len(heading))
        end = len(text) if end < 0 else end + 1
        old = text[start:end]
        kept = old.find("\n### ")
        tail = old[kept + 1:] if kept >= 0 else ""
        new = section.rstrip("\n") + "\n" + ("\n" + tail if tail else "")
        rest = text[end:]
        if rest and not new.endswith("\n\n"):
            new += "\n"  # a blank line before the next section
        text = text[:start] + new + rest
    text = text.rstrip("\n") + "\n"
    with atomic_write(path) as f:
        f.write(text)
