"""A StarCraft II replay file, decoded with Blizzard's `s2protocol`, without the game.

    replay = open_replay("game.SC2Replay")
    replay.base_build, replay.game_loops, replay.details, replay.game_events()

A replay's protocol module is chosen by its base build: the exact one if s2protocol has
it, else the nearest lower one (a build without a module of its own, such as 4.10.4's
76811, decodes with the last protocol before it). A replay decoded with a module not of
its own build is validated before use: every game and tracker event must decode, and
the last game event must fall on the header's last game loop. Anything else is a
`ReplayError` that names the file and the reason, so that a converter can skip it.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import re
import sys
from types import ModuleType
from typing import Any

import mpyq

from sc2jax.replay_sl.fast_bits import decoding_fast

_FILES = {"details": "replay.details", "initdata": "replay.initData",
          "attributes": "replay.attributes.events", "game": "replay.game.events",
          "tracker": "replay.tracker.events"}


class ReplayError(ValueError):
    """A replay that cannot be read: corrupt, truncated, or of an unsupported build.

    Attributes:
      path: the file.
      reason: why, in a few words.
    """

    def __init__(self, path: str, reason: str):
        self.path, self.reason = str(path), reason
        super().__init__(f"{path}: {reason}")


def _versions_dir() -> str:
    spec = importlib.util.find_spec("s2protocol")
    if spec is None or not spec.submodule_search_locations:
        raise ImportError("s2protocol is not installed (pip install s2protocol)")
    return os.path.join(spec.submodule_search_locations[0], "versions")


@functools.cache
def protocol_builds() -> tuple[int, ...]:
    """The base builds that s2protocol has a protocol module for, ascending."""
    found = (re.fullmatch(r"protocol(\d+)\.py", n) for n in os.listdir(_versions_dir()))
    return tuple(sorted(int(m.group(1)) for m in found if m))


@functools.cache
def protocol_module(build: int) -> ModuleType:
    """s2protocol's protocol module of a build, loaded from its file (s2protocol's own
    loader uses `imp`, which Python 3.12 removed)."""
    name = f"s2protocol.versions.protocol{build}"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            name, os.path.join(_versions_dir(), f"protocol{build}.py"))
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules[name] = module
    return sys.modules[name]


def protocol_build_for(base_build: int) -> int:
    """The protocol module's build for a replay's base build: the same, or the nearest
    lower one. Raises ValueError for a build older than every module."""
    lower = [b for b in protocol_builds() if b <= base_build]
    if not lower:
        raise ValueError(f"base build {base_build} is older than every protocol s2protocol "
                         f"has (the oldest is {protocol_builds()[0]})")
    return lower[-1]


class Replay:
    """One replay file's decoded streams (use `open_replay`).

    Attributes:
      path: the file.
      base_build: the game's base build (from the header).
      version: the game's version, e.g. "4.10.4.76811".
      game_loops: the replay's length in game loops (22.4 per real second at Faster).
      protocol_build: the build of the s2protocol module that decodes it.
      details, initdata, attributes: the decoded metadata streams (dicts).
    """

    def __init__(self, path: str | os.PathLike):
        self._decoded: dict[str, list[dict]] = {}
        self.path = str(path)
        self._archive, header = _read_header(self.path)
        v = header["m_version"]
        self.base_build = int(v["m_baseBuild"])
        self.version = f"{v['m_major']}.{v['m_minor']}.{v['m_revision']}.{v['m_build']}"
        self.game_loops = int(header["m_elapsedGameLoops"])
        try:
            self.protocol_build = protocol_build_for(self.base_build)
            self._protocol = protocol_module(self.protocol_build)
        except (ValueError, ImportError) as error:
            raise ReplayError(self.path, f"unsupported build: {error}") from None
        self.details = self._decode("details", "decode_replay_details")
        self.initdata = self._decode("initdata", "decode_replay_initdata")
        self.attributes = self._decode("attributes", "decode_replay_attributes_events")
        if self.protocol_build != self.base_build:
            self._validate()

    def _read(self, stream: str) -> bytes:
        data = self._archive.read_file(_FILES[stream])
        if data is None:
            raise ReplayError(self.path, f"the archive has no {_FILES[stream]}")
        return data

    def _decode(self, stream: str, decoder: str) -> Any:
        data = self._read(stream)
        try:
            with decoding_fast():
                return getattr(self._protocol, decoder)(data)
        except Exception as error:
            raise ReplayError(self.path, f"{_FILES[stream]} does not decode "
                                         f"({type(error).__name__}: {error})") from None

    def _events(self, stream: str, decoder: str) -> list[dict]:
        if stream not in self._decoded:  # Decoded once: labels and units both read them.
            data = self._read(stream)
            try:
                with decoding_fast():
                    self._decoded[stream] = list(getattr(self._protocol, decoder)(data))
            except Exception as error:
                raise ReplayError(self.path, f"{_FILES[stream]} does not decode to its end "
                                             f"({type(error).__name__}: {error})") from None
        return self._decoded[stream]

    def game_events(self) -> list[dict]:
        """Every user's game events in order (observers' too), as s2protocol decodes them
        (decoded on the first call, then kept)."""
        return self._events("game", "decode_replay_game_events")

    def tracker_events(self) -> list[dict]:
        """The tracker events (units born, died, positions, player stats...) in order
        (decoded on the first call, then kept)."""
        return self._events("tracker", "decode_replay_tracker_events")

    def _validate(self) -> None:
        last = None
        for event in self.game_events():
            last = event
        for _ in self.tracker_events():
            pass
        if last is None or last["_gameloop"] != self.game_loops:
            loop = None if last is None else last["_gameloop"]
            raise ReplayError(self.path, f"decoded with the protocol of build "
                                         f"{self.protocol_build} (none for {self.base_build}), "
                                         f"its last game event is at loop {loop}, not at the "
                                         f"header's {self.game_loops}")


def _read_header(path: str) -> tuple[mpyq.MPQArchive, dict]:
    """A replay's archive and its decoded header (which every build's protocol reads)."""
    try:
        archive = mpyq.MPQArchive(path)
        return archive, protocol_module(protocol_builds()[-1]).decode_replay_header(
            archive.header["user_data_header"]["content"])
    except Exception as error:  # mpyq and s2protocol raise many kinds on bad bytes.
        raise ReplayError(path, f"not a readable replay archive "
                                f"({type(error).__name__}: {error})") from None


def base_build(path: str | os.PathLike) -> int:
    """The base build of the game that wrote a replay, from its header alone.

    Raises:
      ReplayError: for a file that is not a readable replay archive.
    """
    return int(_read_header(str(path))[1]["m_version"]["m_baseBuild"])


def open_replay(path: str | os.PathLike) -> Replay:
    """Opens and decodes a replay's header and metadata (the events decode lazily).

    Raises:
      FileNotFoundError: if `path` does not exist.
      ReplayError: for a corrupt, truncated or unsupported replay.
    """
    if not os.path.isfile(path):
        raise FileNotFoundError(f"no replay file at {str(path)!r}")
    return Replay(path)
