"""Every Python example in README.md, BUILD.md and docs/ runs as written (the blocks of a
page in order, in one namespace), except blocks that say they need StarCraft II."""

import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).parents[1]
PAGES = [ROOT / "README.md", ROOT / "BUILD.md", *sorted((ROOT / "docs").glob("*.md"))]
NEEDS_THE_GAME = "# Needs StarCraft II"


def python_blocks(page: pathlib.Path) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", page.read_text(), re.S | re.M)


def test_the_pages_have_examples_and_each_runs_or_says_why_not():
    runnable = {p.name: [b for b in python_blocks(p) if not b.startswith(NEEDS_THE_GAME)]
                for p in PAGES}
    assert runnable["README.md"] and runnable["usage.md"] and runnable["networks.md"]


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if python_blocks(p)],
                         ids=lambda p: p.name)
def test_the_examples_run(page):
    namespace = {"__name__": f"example_{page.stem}"}
    for number, block in enumerate(python_blocks(page)):
        if block.startswith(NEEDS_THE_GAME):
            continue
        exec(compile(block, f"{page.name} example {number}", "exec"), namespace)
