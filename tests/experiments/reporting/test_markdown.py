"""`markdown.write_section`: the benchmark scripts' one way of updating docs."""

import pytest

from sc2jax.experiments.reporting.markdown import write_section


def test_replaces_appends_and_keeps_subsections(tmp_path):
    path = tmp_path / "b.md"
    path.write_text("# Benchmarks\n\n## A\n\nold a\n\n### Notes\n\nkept\n\n## B\n\nold b\n")
    write_section(str(path), "## A\n\nnew a\n")
    write_section(str(path), "## C\n\nnew c\n")
    assert path.read_text() == ("# Benchmarks\n\n## A\n\nnew a\n\n### Notes\n\nkept\n\n"
                                "## B\n\nold b\n\n## C\n\nnew c\n")
    write_section(str(path), "## B\n\nnew b\n")
    assert "## B\n\nnew b\n\n## C" in path.read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.md"]  # no temporary left


def test_needs_a_heading(tmp_path):
    with pytest.raises(ValueError, match="## "):
        write_section(str(tmp_path / "b.md"), "no heading")
