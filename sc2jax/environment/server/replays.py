"""The simulator's replays: an episode's first key and the calls applied at each step.

The simulator is deterministic, so an episode is its key and its players' calls: played
again through the same compiled programs, they give the same states. `save_replay`
writes one, `start_replay` plays it back. On the wire a replay is UTF-8 JSON that starts
with `MAGIC`; the real game's `.SC2Replay` files are MPQ archives, which this server does
not read (`Replay.from_bytes` says so).
"""

from __future__ import annotations

import dataclasses
import json

from sc2jax.environment.interface.functions import FunctionCall

MAGIC = b'{"sc2jax_replay": 1'
"""How a simulator replay begins (its JSON's first key and the format's version)."""


@dataclasses.dataclass(frozen=True)
class Replay:
    """One simulator episode.

    Attributes:
      map_name: the mini-game.
      map_path: the map path the game was created with.
      key: the episode's PRNG key data (`jax.random.PRNGKey` words).
      screen_size, minimap_size: the (x, y) resolutions its calls' points are in.
      steps: (game loops run, the calls applied before them) for each step.
      result: the player's `sc2api.Result` if the episode ended, else None.
    """

    map_name: str
    map_path: str
    key: list[int]
    screen_size: tuple[int, int]
    minimap_size: tuple[int, int]
    steps: list[tuple[int, list[FunctionCall]]]
    result: int | None

    @property
    def game_loops(self) -> int:
        return sum(loops for loops, _ in self.steps)

    def to_bytes(self) -> bytes:
        body = {"map_name": self.map_name, "map_path": self.map_path, "key": self.key,
                "screen_size": list(self.screen_size),
                "minimap_size": list(self.minimap_size), "result": self.result,
                "steps": [[loops, [[int(c.function), [list(map(int, a)) for a in c.arguments]]
                                   for c in calls]] for loops, calls in self.steps]}
        return MAGIC + b", " + json.dumps(body, separators=(",", ":")).encode()[1:]

    @classmethod
    def from_bytes(cls, data: bytes) -> Replay:
        """Raises ValueError for bytes that are not a simulator replay."""
        if not data.startswith(MAGIC):
            kind = "a StarCraft II replay (MPQ)" if data[:3] == b"MPQ" else "not a replay"
            raise ValueError(f"the sc2jax simulator plays back its own replays (save_replay); "
                             f"these {len(data)} bytes are {kind}")
        try:
            body = json.loads(data)
            steps = [(int(loops), [FunctionCall(int(f), [list(a) for a in args])
                                   for f, args in calls]) for loops, calls in body["steps"]]
            return cls(str(body["map_name"]), str(body["map_path"]),
                       [int(k) for k in body["key"]], tuple(body["screen_size"]),
                       tuple(body["minimap_size"]), steps, body["result"])
        except (ValueError, KeyError, TypeError) as e:
            raise ValueError(f"a damaged simulator replay: {type(e).__name__}: {e}") from None
