"""Installs the seven mini-game maps into a StarCraft II install, for the real game.

    python -m sc2jax.environment.sc2api.install_maps                 # into $SC2PATH/Maps/mini_games
    python -m sc2jax.environment.sc2api.install_maps --sdist pysc2-evolved-1.1.1.tar.gz --sc2path D

The real maps ship in the source distribution of `pysc2-evolved` 1.1.1 on PyPI (Apache-2.0),
under `src/pysc2_evolved/maps/mini_games/` (reference/maps.md). Without `--sdist`, this
command fetches that distribution with `pip download` (an install step the user runs, like
`pip install`; nothing in sc2jax downloads at run time). Each map is written atomically.
Ladder maps (for the full game) come from Blizzard's map packs: see BUILD.md.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Sequence

from sc2jax.atomic import atomic_write
from sc2jax.environment.interface.map_names import MINI_GAMES as MAPS
from sc2jax.environment.sc2api.launcher import sc2path

SDIST = "pysc2-evolved==1.1.1"
MAPS_IN_SDIST = "src/pysc2_evolved/maps/mini_games/"


def maps_from_sdist(sdist: str | os.PathLike) -> dict[str, bytes]:
    """The mini-game maps in a `pysc2-evolved` source tarball, by file name.

    Raises:
      ValueError: if the tarball lacks any of the seven maps.
    """
    found = {}
    with tarfile.open(sdist) as tar:
        for member in tar.getmembers():
            parts = member.name.split("/", 1)
            if (member.isfile() and len(parts) == 2 and parts[1].startswith(MAPS_IN_SDIST)
                    and member.name.endswith(".SC2Map")):
                found[pathlib.PurePosixPath(member.name).name] = tar.extractfile(member).read()
    missing = sorted(f"{name}.SC2Map" for name in MAPS if f"{name}.SC2Map" not in found)
    if missing:
        raise ValueError(f"{str(sdist)!r} lacks the mini-game maps {missing} under "
                         f"{MAPS_IN_SDIST!r}; expected the {SDIST} source distribution")
    return found


def install(maps: dict[str, bytes], root: pathlib.Path) -> list[pathlib.Path]:
    """Writes the maps into `root/Maps/mini_games/`; returns their paths."""
    written = []
    for name, data in sorted(maps.items()):
        path = root / "Maps" / "mini_games" / name
        with atomic_write(path, "wb") as f:
            f.write(data)
        written.append(path)
    return written


def download_sdist(directory: str) -> pathlib.Path:
    """`pip download`s the source distribution into `directory`."""
    subprocess.run([sys.executable, "-m", "pip", "download", "--no-deps", "--no-binary",
                    ":all:", SDIST, "-d", directory], check=True)
    tarballs = sorted(pathlib.Path(directory).glob("pysc2*evolved-*.tar.gz"))
    if not tarballs:
        raise FileNotFoundError(f"pip download of {SDIST} gave no source tarball")
    return tarballs[0]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sc2jax.environment.sc2api.install_maps",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--sc2path", help="the install (default: $SC2PATH or the "
                                          "platform's default)")
    parser.add_argument("--sdist", help=f"a local {SDIST} source tarball (default: "
                                        f"pip download it)")
    args = parser.parse_args(argv)
    root = sc2path(args.sc2path)
    with tempfile.TemporaryDirectory() as tmp:
        sdist = args.sdist or download_sdist(tmp)
        written = install(maps_from_sdist(sdist), root)
    for path in written:
        print(f"installed {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
