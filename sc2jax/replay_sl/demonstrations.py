"""Demonstrations: episodes played in the simulator, written as a replay dataset.

An agent (random, scripted, or a trained network) plays a mini-game in `num_envs`
simulator environments at once, one episode each; every agent step becomes a record of
the replay datasets' schema (`dataset.schema`), so `train_replays` and the loader read
demonstrations as they read converted replays. Unlike a replay's, the observation, the
`available_actions` mask (the game's own) and the label (the action the agent sent) are
exact.

The mini-games have no win or loss, so the value target is 1 for an episode whose score
is above the median score of its batch (the `num_envs` episodes played together), else
0: the value head learns whether an episode goes better than the demonstrator's typical
one.

Each episode is one shard, named after the map, agent, seed and episode and split
90/10 by the SHA-1 of that name (`dataset.split_of`). Episodes are played in batches
whose keys come from the seed and the batch's index, so a recording that is run again
skips the batches whose shards are all there and plays the others as it would have
(`batch_keys`).

    def act(key, carry, obs, first):  # a `Policy` of one environment, batched
        return carry, jax.vmap(policy)(jax.random.split(key, first.shape[0]), obs)

    record_demonstrations(sim, act, None, "/tmp/demos",
                          Recording("MoveToBeacon", "scripted", seed=0, num_envs=16), 100)
"""

from __future__ import annotations

import dataclasses
import hashlib
import pathlib
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.atomic import write_json_atomic
from sc2jax.checks import check_positive_int
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES
from sc2jax.replay_sl.dataset import (
    FORMAT,
    WRITER_OPTIONS,
    Settings,
    dataset_settings,
    encode,
    packed_layers,
    read_shard,
    read_summary,
    schema,
    shard_name,
    split_of,
    write_shard,
)

Act = Callable[[jax.Array, Any, dict, jax.Array], tuple[Any, DenseAction]]
"""`act(key, carry, observation, first) -> (carry, action)`: a batched agent, with
observation leaves [B, ...] (the simulator's padded layout), first bool[B] and actions
[B]; `carry` is its recurrent state (None for a feed-forward agent)."""

CHUNK = 16
"""Agent steps played per compiled call before the host writes them."""


@dataclasses.dataclass(frozen=True)
class Recording:
    """What a demonstration dataset holds (kept in `conversion.json`).

    Attributes:
      map_name: the mini-game.
      agent: the agent's name (part of the shards' names).
      seed: the episodes' seed.
      num_envs: episodes played together (a batch).
    """

    map_name: str
    agent: str
    seed: int
    num_envs: int


def episode_name(recording: Recording, episode: int) -> str:
    return f"{recording.map_name}-{recording.agent}-s{recording.seed}-e{episode:06d}"


def _episode_shard(output: pathlib.Path, recording: Recording, episode: int) -> pathlib.Path:
    name = episode_name(recording, episode)
    sha1 = hashlib.sha1(name.encode()).hexdigest()
    return output / split_of(sha1) / shard_name(name, sha1)


def _chunk_fn(sim: Simulator, act: Act):
    """A jitted `(carry, key) -> (carry, steps, rewards)` playing `CHUNK` steps of every
    environment: steps are the records' fields [CHUNK, B, ...] and `live` (the
    environment's episode had not ended before the step)."""
    step = jax.vmap(lambda state, action, obs: sim.step(state, action, previous=obs))

    def body(loop, key):
        state, ts, carry, done = loop
        obs = ts.observation
        carry, action = act(key, carry, obs, ts.first())
        record = {**packed_layers(obs), "player": obs["player"],
                  "available_actions_mask": obs["available_actions_mask"],
                  "game_loop": obs["game_loop"][:, 0], "live": ~done,
                  **{f"action_{name}": value for name, value in action._asdict().items()}}
        state, ts = step(state, action, obs)
        reward = jnp.where(done, 0.0, ts.reward)
        return (state, ts, carry, done | ts.last()), (record, reward)

    return jax.jit(lambda loop, key: jax.lax.scan(body, loop, jax.random.split(key, CHUNK)))


def batch_keys(recording: Recording, batch: int) -> tuple[jax.Array, jax.Array]:
    """(the reset keys of batch `batch`'s environments [num_envs], the agent's key)."""
    reset_key, act_key = jax.random.split(
        jax.random.fold_in(jax.random.PRNGKey(recording.seed), batch))
    return jax.random.split(reset_key, recording.num_envs), act_key


def _play_batch(reset, play, carry: Any, keys: tuple[jax.Array, jax.Array],
                partial: list[pathlib.Path], fields: dict) -> tuple[np.ndarray, list[int]]:
    """Plays one episode in each environment of `keys` (`batch_keys`), reset by `reset`
    (the jitted `vmap(sim.reset)`), with `play` (`_chunk_fn`), streaming each episode's
    records (value 0) into its file of `partial`.

    Returns:
      (float64[num_envs] the episodes' scores, their lengths in agent steps).
    """
    from array_record.python.array_record_module import ArrayRecordWriter

    reset_keys, key = keys
    num_envs = len(partial)
    state, ts = reset(reset_keys)
    loop = (state, ts, carry, jnp.zeros(num_envs, bool))
    writers = [ArrayRecordWriter(str(p), WRITER_OPTIONS) for p in partial]
    scores, lengths = np.zeros(num_envs), [0] * num_envs
    zero = np.float32(0)
    try:
        while True:
            key, chunk_key = jax.random.split(key)
            loop, (steps, rewards) = play(loop, chunk_key)
            steps, rewards = jax.device_get((steps, rewards))
            scores += rewards.sum(axis=0)
            for t, b in zip(*np.nonzero(steps["live"])):
                record = {name: steps[name][t, b] for name in fields if name != "value"}
                writers[b].write(encode({**record, "value": zero}, fields))
                lengths[b] += 1
            if bool(np.asarray(loop[3]).all()):
                break
    finally:
        for writer in writers:
            writer.close()
    return scores, lengths


def _finish(partial: pathlib.Path, shard: pathlib.Path, value: float, fields: dict) -> None:
    """Writes `partial`'s records, their value set, as `shard` (atomically), and removes
    `partial`."""
    target = np.float32(value)
    write_shard(shard, ({**record, "value": target} for record in read_shard(partial, fields)),
                fields)
    partial.unlink()


def record_demonstrations(sim: Simulator, act: Act, carry: Any, output: str | pathlib.Path,
                          recording: Recording, episodes: int, *, log=print) -> dict:
    """Plays `episodes` episodes and writes them as a dataset in `output`, resuming a
    recording with the same settings that is already there.

    Args:
      sim: the mini-game's simulator.
      act: the agent (`Act`), for `recording.num_envs` environments.
      carry: its initial recurrent state for that many (None for a feed-forward agent).
      output: the dataset's folder.
      recording: the map, agent, seed and batch size.
      episodes: how many episodes (rounded up to whole batches).

    Returns:
      The summary `conversion.json` holds: the format, settings, recording, and each
      episode's shard, split, records and score.

    Raises:
      ValueError: for a bad count, or an `output` holding another dataset.
    """
    check_positive_int("episodes", episodes)
    check_positive_int("num_envs", recording.num_envs)
    fmt = sim.fmt
    settings = Settings(screen_size=fmt.screen_size[0], minimap_size=fmt.minimap_size[0],
                        step_mul=sim.step_mul)
    if fmt.screen_size[0] != fmt.screen_size[1] or fmt.minimap_size[0] != fmt.minimap_size[1]:
        raise ValueError(f"demonstrations need square layers, got screen {fmt.screen_size} "
                         f"and minimap {fmt.minimap_size}")
    if (len(fmt.screen_layers), len(fmt.minimap_layers)) != (
            len(SCREEN_FEATURES), len(MINIMAP_FEATURES)):
        raise ValueError("demonstrations record every feature layer (the datasets' schema); "
                         "build the simulator with screen_features and minimap_features None")
    output = pathlib.Path(output)
    summary = {"format": FORMAT, "settings": dataclasses.asdict(settings),
               "recording": dataclasses.asdict(recording), "replays": [], "failed": []}
    if (output / "conversion.json").exists():
        before = read_summary(output)
        if dataset_settings(output) != settings or before.get("recording") != summary[
                "recording"]:
            raise ValueError(f"{str(output)!r} holds another dataset ({before['settings']}, "
                             f"recording {before.get('recording')}); record into another "
                             f"folder, or with those settings")
        summary["replays"] = before["replays"]
    fields, play = schema(settings), _chunk_fn(sim, act)
    reset = jax.jit(jax.vmap(sim.reset))  # Eagerly, each operation would compile alone.
    num_envs = recording.num_envs
    batches = -(-episodes // num_envs)
    for batch in range(batches):
        numbers = range(batch * num_envs, (batch + 1) * num_envs)
        shards = [_episode_shard(output, recording, e) for e in numbers]
        if all(s.exists() for s in shards):
            log(f"batch {batch + 1}/{batches}: already there")
            continue
        partial = [output / ".partial" / f"{episode_name(recording, e)}.array_record"
                   for e in numbers]
        partial[0].parent.mkdir(parents=True, exist_ok=True)
        scores, lengths = _play_batch(reset, play, carry, batch_keys(recording, batch),
                                      partial, fields)
        median = float(np.median(scores))
        done = {r["episode"] for r in summary["replays"]}
        for e, shard, path, score, length in zip(numbers, shards, partial, scores, lengths):
            if shard.exists():  # Written before an interruption: the same records.
                path.unlink()
            else:
                _finish(path, shard, float(score > median), fields)
            if e not in done:
                summary["replays"].append({
                    "replay": episode_name(recording, e), "episode": e,
                    "split": shard.parent.name, "shard": str(shard), "records": length,
                    "score": float(score), "value": float(score > median)})
        write_json_atomic(output / "conversion.json", summary)
        log(f"batch {batch + 1}/{batches}: {num_envs} episodes, mean score "
            f"{scores.mean():.2f}, {sum(lengths)} records")
    write_json_atomic(output / "conversion.json", summary)
    if (output / ".partial").is_dir() and not any((output / ".partial").iterdir()):
        (output / ".partial").rmdir()
    return summary
