"""BUILD.md's dependency tables name every requirement of setup.cfg, at its lower bound,
and nothing else (issue 66: documents in step with the code)."""

import configparser
import pathlib
import re

ROOT = pathlib.Path(__file__).parents[1]


def _requirements(text: str) -> dict[str, str]:
    pairs = (re.fullmatch(r"([A-Za-z0-9_.-]+)>=([0-9.]+)", line.strip())
             for line in text.strip().splitlines() if line.strip())
    return {m.group(1): m.group(2) for m in pairs}


def _documented() -> dict[str, str]:
    """Package -> lower bound, from the rows of BUILD.md's tables (`name` ≥ version)."""
    found = {}
    for line in (ROOT / "BUILD.md").read_text().splitlines():
        if line.startswith("| `"):
            cell = line.split("|")[1]
            for name, bound in re.findall(r"`([A-Za-z0-9_.-]+)` ≥ ([0-9.]+)", cell):
                found[name] = bound
    return found


def test_build_md_lists_every_requirement_at_its_lower_bound():
    config = configparser.ConfigParser()
    config.read(ROOT / "setup.cfg")
    required = {**_requirements(config["options"]["install_requires"]),
                **_requirements(config["options.extras_require"]["test"])}
    documented = _documented()
    assert required, "no requirements parsed from setup.cfg"
    missing = {n: v for n, v in required.items() if n not in documented}
    extra = {n: v for n, v in documented.items() if n not in required}
    assert not missing and not extra, f"not in BUILD.md: {missing}; not required: {extra}"
    # BUILD.md shortens versions with a fourth part (s2protocol 5.0.17.98310.0 -> 5.0.17).
    wrong = {n: (documented[n], v) for n, v in required.items()
             if not v.startswith(documented[n])}
    assert not wrong, f"BUILD.md's bound differs from setup.cfg's: {wrong}"
