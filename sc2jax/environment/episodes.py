"""Recorded episodes of the simulator: the map, the reset key and the actions.

The simulator is deterministic: the same reset key and the same actions give the same
episode, bit for bit. So an episode is saved compactly as its settings, the key its
state was reset with, and its `DenseAction`s, one per agent step (a 240-step episode is
a few kilobytes). `replay` recomputes every state, observation and reward from them.
`Episode.rewards` keeps the rewards seen when it was recorded, so a replay can be checked
against them (`check_replay`).

Files are NumPy `.npz` archives (`save_episode`, `load_episode`), written atomically.
"""

from __future__ import annotations

import dataclasses
import functools
import io
import os
import zipfile

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.atomic import atomic_write
from sc2jax.environment.engine.compiled import simulator
from sc2jax.environment.engine.minigames import check_map
from sc2jax.environment.engine.simulator import EnvParams, Simulator
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.dense import DenseAction

FORMAT = "sc2jax-episode-1"
"""The file format's name and version, stored in every file."""


class EpisodeError(ValueError):
    """An episode file that cannot be read: missing, corrupt, or of another format."""


@dataclasses.dataclass(frozen=True)
class Episode:
    """One recorded episode of the simulator.

    Attributes:
      map_name: the mini-game.
      screen_size, minimap_size: (x, y) resolutions the actions' points refer to.
      step_mul: game loops per agent step.
      score_index, score_multiplier: the reward (as `Simulator`).
      game_steps_per_episode: the episode limit in game loops (0: the map's own).
      key: uint32[2] the key the episode's state was reset with.
      actions: a `DenseAction` whose fields have a leading [T] axis (int32).
      rewards: float32[T] the reward of each step when recorded.
      agent: who played (free text: "random", a run directory, "human", ...).
    """

    map_name: str
    screen_size: tuple[int, int]
    minimap_size: tuple[int, int]
    step_mul: int
    key: np.ndarray
    actions: DenseAction
    rewards: np.ndarray
    score_index: int = 0
    score_multiplier: float = 1.0
    game_steps_per_episode: int = 0
    agent: str = ""

    def __post_init__(self):
        check_map(self.map_name)
        steps = len(self.rewards)
        for name, field in zip(DenseAction._fields, self.actions):
            if np.shape(field)[:1] != (steps,):
                raise ValueError(f"action field {name} has shape {np.shape(field)}; every "
                                 f"field needs a leading axis of the {steps} steps")
        if np.shape(self.key) != (2,):
            raise ValueError(f"key must be uint32[2], got shape {np.shape(self.key)}")

    @property
    def num_steps(self) -> int:
        return len(self.rewards)

    @property
    def score(self) -> float:
        """The recorded return: the sum of the rewards."""
        return float(np.sum(self.rewards, dtype=np.float64))

    def simulator(self, fmt: specs.ObservationFormat | None = None) -> Simulator:
        """The simulator that replays it, rendering `fmt` (default: every layer at the
        recorded resolutions; the layers do not change the game)."""
        fmt = fmt or specs.ObservationFormat(screen_size=self.screen_size,
                                             minimap_size=self.minimap_size)
        if (fmt.screen_size, fmt.minimap_size) != (tuple(self.screen_size),
                                                   tuple(self.minimap_size)):
            raise ValueError(f"the episode's actions are at screen {self.screen_size} and "
                             f"minimap {self.minimap_size}; fmt has {fmt.screen_size} and "
                             f"{fmt.minimap_size}")
        return simulator(self.map_name, fmt, self.step_mul, self.score_index,
                         float(self.score_multiplier), 1.0, False)

    @property
    def params(self) -> EnvParams:
        return EnvParams(game_steps_per_episode=np.int32(self.game_steps_per_episode))


@functools.cache
def _replay_fn(sim: Simulator):
    """jit((keys [B], actions [T, B], params) -> (states [B, T + 1], timesteps [B, T + 1]))."""

    def run(key, actions, params):
        state, first = sim.reset(key, params)

        def body(state, action):
            state, timestep = sim.step(state, action, params)
            return state, (state, timestep)

        _, (states, timesteps) = jax.lax.scan(body, state, actions)
        return jax.tree.map(lambda a, b: jnp.concatenate([a[None], b]), (state, first),
                            (states, timesteps))

    return jax.jit(jax.vmap(run, in_axes=(0, 1, None)))


def replay(episodes: Episode | list[Episode], fmt: specs.ObservationFormat | None = None,
           pad_to: int | None = None):
    """Replays an episode, or several of the same settings side by side, in the simulator.

    Args:
      episodes: an `Episode`, or a list of episodes whose settings (map, sizes, step_mul,
        reward, limit) are the same; shorter ones are padded with `no_op`s, whose steps
        (after the episode's end: a new episode) are returned too.
      fmt: the layers to render (default: every layer; see `Episode.simulator`).
      pad_to: replay at least this many steps, padding with `no_op`s (one compiled
        program for episodes of any length up to it; `max_steps` is the map's longest).

    Returns:
      (states, timesteps): the `EnvState` and the `dm_env.TimeStep` (padded layout) after
      the reset and after each step, each leaf with a leading [T + 1] axis, or
      [B, T_max + 1] for a list.

    Raises:
      ValueError: for an empty list or episodes of different settings.
    """
    batch = list(episodes) if isinstance(episodes, (list, tuple)) else [episodes]
    if not batch:
        raise ValueError("no episodes to replay")
    settings = {_settings(e) for e in batch}
    if len(settings) > 1:
        raise ValueError(f"episodes replayed together need the same settings; got "
                         f"{sorted(settings)}")
    length = max([e.num_steps for e in batch] + [pad_to or 0])
    actions = DenseAction(*(np.stack([
        np.pad(np.asarray(field, np.int32), [(0, length - e.num_steps)]
               + [(0, 0)] * (np.ndim(field) - 1))
        for e, field in zip(batch, fields)], axis=1)
        for fields in zip(*(e.actions for e in batch))))
    keys = np.stack([np.asarray(e.key, np.uint32) for e in batch])
    out = _replay_fn(batch[0].simulator(fmt))(keys, actions, batch[0].params)
    return out if isinstance(episodes, (list, tuple)) else jax.tree.map(lambda x: x[0], out)


def max_steps(episode: Episode) -> int:
    """The agent steps of the map's longest episode (its timer) at the episode's step_mul."""
    return -(-episode.simulator().game.time_limit_loops // episode.step_mul)


def replay_whole(episode: Episode, fmt: specs.ObservationFormat | None = None):
    """`replay` of one episode through one compiled program for every length (padded to
    the map's longest episode, `max_steps`), trimmed back to its own T + 1 timesteps."""
    states, timesteps = replay(episode, fmt, pad_to=max_steps(episode))
    end = episode.num_steps + 1
    return jax.tree.map(lambda x: x[:end], (states, timesteps))


def _settings(episode: Episode) -> tuple:
    return (episode.map_name, tuple(episode.screen_size), tuple(episode.minimap_size),
            episode.step_mul, episode.score_index, episode.score_multiplier,
            episode.game_steps_per_episode)


def check_replay(episode: Episode, timesteps) -> None:
    """Raises AssertionError unless a replay's rewards equal the recorded ones bit for bit."""
    rewards = np.asarray(timesteps.reward)[1:]
    if not np.array_equal(rewards, np.asarray(episode.rewards, np.float32)):
        where = np.flatnonzero(rewards != episode.rewards)
        raise AssertionError(f"the replay's rewards differ from the recorded ones at steps "
                             f"{where[:10].tolist()} (score {rewards.sum()} against "
                             f"{episode.score})")


def save_episode(path: str | os.PathLike, episode: Episode) -> None:
    """Writes an episode to a `.npz` file, atomically."""
    arrays = {f"action_{name}": np.asarray(field, np.int32)
              for name, field in zip(DenseAction._fields, episode.actions)}
    arrays.update(
        format=np.str_(FORMAT), map_name=np.str_(episode.map_name),
        agent=np.str_(episode.agent), key=np.asarray(episode.key, np.uint32),
        rewards=np.asarray(episode.rewards, np.float32),
        screen_size=np.asarray(episode.screen_size, np.int32),
        minimap_size=np.asarray(episode.minimap_size, np.int32),
        step_mul=np.int32(episode.step_mul), score_index=np.int32(episode.score_index),
        score_multiplier=np.float64(episode.score_multiplier),
        game_steps_per_episode=np.int32(episode.game_steps_per_episode))
    with atomic_write(path, "wb") as f:
        np.savez_compressed(f, **arrays)


def load_episode(path: str | os.PathLike) -> Episode:
    """Reads an episode written by `save_episode`.

    Raises:
      EpisodeError: the file is missing, is not an episode file, is of another format
        version, or holds bad values.
    """
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        raise EpisodeError(f"no episode file at {path!r}") from None
    except OSError as error:
        raise EpisodeError(f"cannot read {path!r}: {error.strerror}") from None
    if not data.startswith(b"PK"):
        raise EpisodeError(f"{path!r} is not an episode file (not a NumPy .npz archive)")
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {name: z[name] for name in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as error:
        raise EpisodeError(f"{path!r} is not a readable episode file ({error})") from None
    fmt = str(arrays.get("format", ""))
    if fmt != FORMAT:
        raise EpisodeError(f"{path!r} is not an episode file of format {FORMAT!r} (its "
                           f"format: {fmt or 'none'!r})")
    try:
        return Episode(
            map_name=str(arrays["map_name"]), agent=str(arrays["agent"]),
            screen_size=tuple(int(v) for v in arrays["screen_size"]),
            minimap_size=tuple(int(v) for v in arrays["minimap_size"]),
            step_mul=int(arrays["step_mul"]), key=arrays["key"].astype(np.uint32),
            actions=DenseAction(*(arrays[f"action_{name}"] for name in DenseAction._fields)),
            rewards=arrays["rewards"].astype(np.float32),
            score_index=int(arrays["score_index"]),
            score_multiplier=float(arrays["score_multiplier"]),
            game_steps_per_episode=int(arrays["game_steps_per_episode"]))
    except (KeyError, ValueError, TypeError) as error:
        raise EpisodeError(f"{path!r} holds a bad episode: {error}") from None
