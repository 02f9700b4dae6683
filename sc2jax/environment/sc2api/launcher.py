"""Finding and launching StarCraft II, as PySC2's `sc_process` and `run_configs` do.

    with launch() as game:            # the newest Versions/Base* under SC2PATH
        game.controller.ping()

The install is `$SC2PATH`, by default `~/StarCraftII` on Linux,
`C:/Program Files (x86)/StarCraft II` on Windows and `/Applications/StarCraft II` on
macOS. The binary is `Versions/Base<build>/SC2_x64` (Linux), `SC2_x64.exe` run from
`Support64` (Windows) or `SC2.app/Contents/MacOS/SC2` (macOS). It is started with
`-listen 127.0.0.1 -port P -dataDir SC2PATH/ -tempDir TMP/`, headless on Linux
(`-headlessNoRender`), on a free port, and waited for with retries. `close` asks the
game to quit, then terminates it, then kills it. Any number can run at once.
"""

from __future__ import annotations

import os
import pathlib
import platform
import re
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Sequence

from sc2jax.environment.sc2api.controller import Controller

DEFAULT_PATHS = {
    "Linux": "~/StarCraftII",
    "Windows": "C:/Program Files (x86)/StarCraft II",
    "Darwin": "/Applications/StarCraft II",
}
MIN_BUILD = 55958
"""SC2 3.16.1, the oldest version PySC2 accepts."""


def sc2path(path: str | os.PathLike | None = None) -> pathlib.Path:
    """The install folder: `path`, else `$SC2PATH`, else the platform's default.

    Raises:
      FileNotFoundError: if the folder or its `Versions` folder does not exist.
    """
    chosen = path or os.environ.get("SC2PATH") or DEFAULT_PATHS.get(platform.system(),
                                                                     DEFAULT_PATHS["Linux"])
    root = pathlib.Path(chosen).expanduser()
    if not (root / "Versions").is_dir():
        raise FileNotFoundError(
            f"no StarCraft II install at {str(root)!r} (no Versions folder); install the "
            f"game there or set SC2PATH (see BUILD.md)")
    return root


def builds(root: pathlib.Path) -> list[int]:
    """The builds installed under `root/Versions` (`Base<build>` folders), ascending."""
    found = (re.fullmatch(r"Base(\d+)", p.name) for p in (root / "Versions").iterdir())
    return sorted(int(m.group(1)) for m in found if m)


def executable(root: pathlib.Path, build: int | None = None) -> tuple[pathlib.Path, pathlib.Path
                                                                       | None]:
    """The game binary of `build` (None: the newest) and the folder to run it from.

    Raises:
      FileNotFoundError: if no build, or not the one asked for, is installed.
      ValueError: for a build older than 3.16.1.
    """
    installed = builds(root)
    if not installed:
        raise FileNotFoundError(f"no Versions/Base* folder under {str(root)!r}")
    if build is None:
        build = installed[-1]
    elif build not in installed:
        raise FileNotFoundError(f"build {build} is not installed under {str(root)!r}; "
                                f"installed: {installed}")
    if build < MIN_BUILD:
        raise ValueError(f"build {build} is older than 3.16.1 ({MIN_BUILD}), which the API "
                         f"needs")
    version = root / "Versions" / f"Base{build:05d}"
    system = platform.system()
    if system == "Windows":
        return version / "SC2_x64.exe", root / "Support64"
    if system == "Darwin":
        return version / "SC2.app" / "Contents" / "MacOS" / "SC2", None
    return version / "SC2_x64", None


def free_port() -> int:
    """A TCP port on 127.0.0.1 that is free now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class GameProcess:
    """A running game (or stand-in) and the `Controller` connected to it."""

    def __init__(self, process: subprocess.Popen, controller: Controller, port: int,
                 temp_dir: str):
        self.process, self.controller, self.port = process, controller, port
        self._temp_dir = temp_dir
        controller.on_quit = self._stop

    def running(self) -> bool:
        return self.process.poll() is None

    def close(self) -> None:
        """Quits the game: RequestQuit, then terminate, then kill (the controller's
        `quit` calls `_stop`); removes its temp dir."""
        self.controller.quit()

    def _stop(self, timeout_seconds: float = 10.0) -> None:
        for stop in (None, self.process.terminate, self.process.kill):
            if stop is not None and self.running():
                stop()
            try:
                self.process.wait(timeout=timeout_seconds)
                break
            except subprocess.TimeoutExpired:
                continue
        shutil.rmtree(self._temp_dir, ignore_errors=True)

    def __enter__(self) -> GameProcess:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def launch(path: str | os.PathLike | None = None, build: int | None = None, *,
           headless: bool = True, extra_args: Sequence[str] = (),
           timeout_seconds: float = 120.0, connect_seconds: float = 360.0,
           log_path: str | os.PathLike | None = None) -> GameProcess:
    """Starts the game and connects to it.

    Args:
      path: the install (default: `sc2path()`'s choice).
      build: the `Versions/Base<build>` to run (default: the newest).
      headless: no window (Linux: `-headlessNoRender`).
      extra_args: more command-line arguments.
      timeout_seconds: the timeout of each request.
      connect_seconds: how long to wait for the game to listen (PySC2: 360 s).
      log_path: where the game's output goes (default: discarded).

    Raises:
      FileNotFoundError, ValueError: for a missing install or build.
      ConnectionError: if the game exits or does not listen in time.
    """
    root = sc2path(path)
    binary, cwd = executable(root, build)
    if not binary.is_file():
        raise FileNotFoundError(f"the game binary {str(binary)!r} does not exist")
    port = free_port()
    temp_dir = tempfile.mkdtemp(prefix="sc2jax-")
    args = [str(binary), "-listen", "127.0.0.1", "-port", str(port),
            "-dataDir", f"{root}{os.sep}", "-tempDir", f"{temp_dir}{os.sep}"]
    if platform.system() == "Linux":
        if headless:
            args.append("-headlessNoRender")
    else:
        args += (["-displayMode", "0", "-windowwidth", "640", "-windowheight", "480",
                  "-windowx", "50", "-windowy", "50"])
    args += list(extra_args)
    env = dict(os.environ)
    if platform.system() == "Linux":
        libs = str(root / "Libs")
        env["LD_LIBRARY_PATH"] = ":".join(p for p in (env.get("LD_LIBRARY_PATH"), libs) if p)
    output = open(log_path, "ab") if log_path else subprocess.DEVNULL
    try:
        process = subprocess.Popen(args, cwd=cwd, env=env, stdout=output,
                                   stderr=subprocess.STDOUT)
    finally:
        if log_path:
            output.close()
    try:
        controller = Controller.connect("127.0.0.1", port, timeout_seconds, connect_seconds,
                                        is_running=lambda: process.poll() is None)
    except BaseException:
        process.kill()
        process.wait()
        shutil.rmtree(temp_dir, ignore_errors=True)
        raise
    return GameProcess(process, controller, port, temp_dir)
