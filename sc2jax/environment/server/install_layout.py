"""A folder that looks like a StarCraft II install and starts the simulator's server.

    python -m sc2jax.environment.server --write-sc2path ~/sc2jax-sc2path
    SC2PATH=~/sc2jax-sc2path python my_pysc2_agent.py

The folder has the Linux layout that launchers (sc2jax's and PySC2's) look for:

    Versions/Base75689/SC2_x64     a script that runs `python -m sc2jax.environment.server`
                                   with the game's command-line arguments
    Maps/mini_games/<Map>.SC2Map   one stand-in file per mini-game and ladder map (the
    Maps/Ladder2019Season*/<Map>LE.SC2Map  server picks the map by its name, not by its
                                   contents; PySC2's map paths)
    Libs/                          empty (launchers add it to LD_LIBRARY_PATH)

so an unmodified SC2-API client launches and plays the simulator instead of the game.
"""

from __future__ import annotations

import os
import pathlib
import shlex
import stat
import sys

from sc2jax.environment.interface.map_names import LADDER_MAP_PATHS
from sc2jax.environment.interface.map_names import MINI_GAMES as MAPS
from sc2jax.environment.server.game_service import BASE_BUILD

MAP_STAND_IN = b"sc2jax: a stand-in for the map %s; the simulator has the map.\n"


def write_sc2path(directory: str | os.PathLike, python: str | None = None) -> pathlib.Path:
    """Writes the layout into `directory` (created if missing) and returns its path.

    Args:
      directory: the folder to write (existing files of the layout are replaced).
      python: the interpreter the script runs (default: this one).

    Raises:
      ValueError: if `directory` exists and is not a folder.
    """
    root = pathlib.Path(directory).expanduser().absolute()
    if root.exists() and not root.is_dir():
        raise ValueError(f"--write-sc2path {str(root)!r} exists and is not a folder")
    binary = root / "Versions" / f"Base{BASE_BUILD:05d}" / "SC2_x64"
    binary.parent.mkdir(parents=True, exist_ok=True)
    interpreter = shlex.quote(python or sys.executable)
    binary.write_text(f"#!/bin/sh\n# sc2jax: the simulator's SC2-API server in place of "
                      f"the game.\nexec {interpreter} -m sc2jax.environment.server \"$@\"\n")
    binary.chmod(binary.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    maps = root / "Maps" / "mini_games"
    maps.mkdir(parents=True, exist_ok=True)
    for name in MAPS:
        (maps / f"{name}.SC2Map").write_bytes(MAP_STAND_IN % name.encode())
    for name, path in LADDER_MAP_PATHS.items():
        (root / "Maps" / path).parent.mkdir(parents=True, exist_ok=True)
        (root / "Maps" / path).write_bytes(MAP_STAND_IN % name.encode())
    (root / "Libs").mkdir(exist_ok=True)
    return root
