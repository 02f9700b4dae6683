"""Replays -> a dataset of PySC2-labelled agent steps, and a loader of minibatches.

Each replay becomes one ArrayRecord shard (`<name>-<sha1[:8]>.array_record`), written to
a temporary file and renamed into place, so that a shard is whole or absent; a
conversion that is run again skips the shards it already has. A shard holds one record
per agent step of each player: the observation (`observations.observe_steps`, with
`available_actions`), the label (a `DenseAction`, from `actions.label_players`) and the
value target (1 for the player who won, 0 for a loss or a tie). A record is its fields'
raw bytes in a fixed order (`schema`, from the settings in `conversion.json`), which
ArrayRecord compresses with zstd; reading one is a view over its bytes, with no parsing.

Replays are split by game, 90/10, by their SHA-1: a game whose hash is 0 modulo 10 is in
"test", so the test set is fixed whatever the order or the number of replays.

Why ArrayRecord and Grain: ArrayRecord files give random access to any record without
reading the rest of the file, so Grain's loader can draw minibatches uniformly across
every step of every game from shards on disk, with a fixed seed, without holding the
dataset in memory; both are maintained by Google and used by its JAX codebases.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import pathlib
from collections.abc import Iterator

import numpy as np

from sc2jax.atomic import write_json_atomic
from sc2jax.checks import check_positive_int
from sc2jax.environment.interface import narrow
from sc2jax.environment.interface.dense import DenseAction, to_dense
from sc2jax.environment.interface.dense import zeros as dense_zeros
from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES
from sc2jax.environment.interface.functions import NUM_FUNCTIONS
from sc2jax.environment.interface.observation_tables import Player
from sc2jax.replay_sl.actions import label_players
from sc2jax.replay_sl.archive import ReplayError, open_replay
from sc2jax.replay_sl.availability import load_cards
from sc2jax.replay_sl.metadata import read_metadata
from sc2jax.replay_sl.observations import View, observe_steps
from sc2jax.replay_sl.units import unit_table

SHARD_SUFFIX = ".array_record"
WRITER_OPTIONS = "group_size:1,zstd:3"
"""ArrayRecord's options: one record per chunk (any record read alone), zstd level 3."""
SPLITS = ("train", "test")
FORMAT = 3
"""The records' format (`conversion.json`): 3 is `schema`'s raw bytes with the feature
layers packed into bytes (2 kept them as uint16; 1 was npz)."""


def split_of(sha1: str) -> str:
    """"test" for one game in ten (by its SHA-1), else "train"."""
    return "test" if int(sha1, 16) % 10 == 0 else "train"


def split_replays(folder: str | os.PathLike, split: str) -> list[str]:
    """The .SC2Replay files under `folder` (searched recursively) in `split`, sorted.

    Raises:
      ValueError: for an unknown split, or a folder with none of the split's replays.
    """
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; allowed: {list(SPLITS)}")
    paths = sorted(str(p) for p in pathlib.Path(folder).rglob("*.SC2Replay"))
    chosen = [p for p in paths
              if split_of(hashlib.sha1(pathlib.Path(p).read_bytes()).hexdigest()) == split]
    if not chosen:
        raise ValueError(f"no {split}-split .SC2Replay files under {str(folder)!r}")
    return chosen


@dataclasses.dataclass(frozen=True)
class Settings:
    """How replays are converted.

    Attributes:
      screen_size, minimap_size: the layers' resolution.
      step_mul: game loops per agent step.
      full_information: draw the enemy's units outside the player's sight too.
      max_steps: convert at most this many agent steps per player (None: all).
      command_cards: a JSON file of the command cards that decide `available_actions`
        (`availability.load_cards`; None: the ones the package ships).
    """

    screen_size: int = 64
    minimap_size: int = 64
    step_mul: int = 8
    full_information: bool = False
    max_steps: int | None = None
    command_cards: str | None = None

    def __post_init__(self):
        for name in ("screen_size", "minimap_size", "step_mul"):
            check_positive_int(name, getattr(self, name))
        if self.max_steps is not None and (isinstance(self.max_steps, bool)
                                           or not isinstance(self.max_steps, int)
                                           or self.max_steps < 1):
            raise ValueError(f"max_steps must be a positive int or None, got "
                             f"{self.max_steps!r}")


def schema(settings: Settings) -> dict[str, tuple[np.dtype, tuple[int, ...]]]:
    """Each field of a record: name -> (dtype, shape)."""
    screen, minimap = settings.screen_size, settings.minimap_size
    fields = {}
    for key, features, size in zip(narrow.LAYER_KEYS, (SCREEN_FEATURES, MINIMAP_FEATURES),
                                   (screen, minimap)):
        fields[key] = (np.uint8, (len(features), size, size))
        fields[key + narrow.HIGH_SUFFIX] = (np.uint8, (len(narrow.wide_channels(features)),
                                                       size, size))
    fields.update({
              "player": (np.int32, (len(Player),)),
              "available_actions_mask": (np.bool_, (NUM_FUNCTIONS,)),
              "game_loop": (np.int32, ()), "value": (np.float32, ())})
    for name, example in zip(DenseAction._fields, dense_zeros(())):
        fields[f"action_{name}"] = (np.int32, np.shape(example))
    return {name: (np.dtype(dtype), shape) for name, (dtype, shape) in fields.items()}


def packed_layers(observation) -> dict:
    """A record's layer fields from an observation's int layers (numpy, or jax inside a
    jitted program): `feature_screen` [27, S, S] and `feature_minimap` [11, M, M], any
    leading axes, packed into bytes (`narrow.pack_observation`)."""
    return narrow.pack_observation({key: observation[key] for key in narrow.LAYER_KEYS},
                                   SCREEN_FEATURES, MINIMAP_FEATURES)


def encode(record: dict[str, np.ndarray], fields: dict) -> bytes:
    """One record (name -> array, as `schema` gives them) as bytes: the fields' raw
    bytes in the schema's order (ArrayRecord compresses them).

    Raises:
      ValueError: for a missing field or a field of another shape.
    """
    parts = []
    for name, (dtype, shape) in fields.items():
        if name not in record or np.shape(record[name]) != shape:
            raise ValueError(f"record field {name!r} must have shape {shape}, got "
                             f"{np.shape(record[name]) if name in record else 'nothing'}")
        parts.append(np.ascontiguousarray(record[name], dtype).tobytes())
    return b"".join(parts)


def decode(data: bytes, fields: dict) -> dict[str, np.ndarray]:
    """The inverse of `encode` (read-only arrays over `data`).

    Raises:
      ValueError: for bytes of another length than the schema's.
    """
    sizes = [int(np.prod(shape)) * dtype.itemsize for dtype, shape in fields.values()]
    if sum(sizes) != len(data):
        raise ValueError(f"a record of {len(data)} bytes does not match the dataset's "
                         f"schema ({sum(sizes)} bytes)")
    out, offset = {}, 0
    for (name, (dtype, shape)), size in zip(fields.items(), sizes):
        out[name] = np.frombuffer(data, dtype, size // dtype.itemsize, offset).reshape(shape)
        offset += size
    return out


def shard_name(path: str | os.PathLike, sha1: str) -> str:
    return f"{pathlib.Path(path).stem}-{sha1[:8]}{SHARD_SUFFIX}"


CHUNK = 64
"""Agent steps rendered together (`observations.observe_steps`)."""


def replay_records(path: str | os.PathLike, settings: Settings) -> Iterator[dict]:
    """Every agent step of every player of a replay, as records (`schema`).

    Raises:
      ReplayError: for a replay that cannot be read.
    """
    replay = open_replay(path)
    metadata = read_metadata(replay)
    labels = label_players(replay, metadata, screen_size=settings.screen_size,
                           minimap_size=settings.minimap_size, step_mul=settings.step_mul)
    table = unit_table(replay)
    cards = load_cards(settings.command_cards)
    description = replay.initdata["m_syncLobbyState"]["m_gameDescription"]
    view = View((int(description["m_mapSizeX"]), int(description["m_mapSizeY"])),
                settings.screen_size, settings.minimap_size, settings.full_information)
    for player in metadata.players:
        label = labels[player.player_id]
        steps = len(label.steps) if settings.max_steps is None else min(
            settings.max_steps, len(label.steps))
        won = np.float32(player.result == "Win")
        for start in range(0, steps, CHUNK):
            chunk = range(start, min(start + CHUNK, steps))
            obs = observe_steps(table, label, player.player_id, view, chunk, cards)
            action = to_dense([label.steps[t].call for t in chunk])
            for n, t in enumerate(chunk):
                yield {**{name: value[n] for name, value in obs.items()},
                       "game_loop": np.int32(label.steps[t].game_loop), "value": won,
                       **{f"action_{name}": value[n]
                          for name, value in action._asdict().items()}}


def convert_replay(path: str | os.PathLike, output: str | os.PathLike,
                   settings: Settings, records=replay_records) -> dict:
    """Converts one replay into its shard under `output/<split>/`, unless it is there:
    the records of `records(path, settings)` (default: decoded without the game).

    Returns:
      {"replay", "sha1", "split", "shard", "records", "skipped": bool}.

    Raises:
      ReplayError: for a replay that cannot be read (no shard is written).
    """
    data = pathlib.Path(path).read_bytes()
    sha1 = hashlib.sha1(data).hexdigest()
    split = split_of(sha1)
    shard = pathlib.Path(output) / split / shard_name(path, sha1)
    info = {"replay": str(path), "sha1": sha1, "split": split, "shard": str(shard)}
    if shard.exists():
        return {**info, "records": None, "skipped": True}
    count = write_shard(shard, records(path, settings), schema(settings))
    return {**info, "records": count, "skipped": False}


def write_shard(shard: pathlib.Path, records, fields: dict) -> int:
    """Writes `records` (dicts of `schema`'s fields) as the ArrayRecord file `shard`,
    atomically: to a temporary file, renamed into place once whole.

    Returns:
      The number of records.
    """
    from array_record.python.array_record_module import ArrayRecordWriter

    shard.parent.mkdir(parents=True, exist_ok=True)
    temporary = shard.with_name(f".{shard.name}.{os.getpid()}.tmp")
    writer = ArrayRecordWriter(str(temporary), WRITER_OPTIONS)
    count = 0
    try:
        for record in records:
            writer.write(encode(record, fields))
            count += 1
        writer.close()
        os.replace(temporary, shard)
    except BaseException:
        writer.close()
        temporary.unlink(missing_ok=True)
        raise
    return count


def _convert_one(args) -> dict:
    path, output, settings, records = args
    try:
        return convert_replay(path, output, settings, records)
    except ReplayError as error:
        return {"replay": str(path), "error": error.reason}
    except OSError as error:  # A file that cannot be read: skipped, as a bad replay is.
        return {"replay": str(path), "error": f"cannot read the file ({error})"}


def convert_replays(paths: list[str], output: str | os.PathLike, settings: Settings, *,
                    processes: int = 1, log=print, records=replay_records) -> dict:
    """Converts replays in parallel; a replay that cannot be read is skipped and counted.
    `records` is `convert_replay`'s (with several processes, a picklable function).

    Writes `output/conversion.json` (the settings, and each replay's shard or the reason
    it has none) after every replay, atomically.

    Returns:
      The summary that `conversion.json` holds.
    """
    import multiprocessing

    check_positive_int("processes", processes)
    output = pathlib.Path(output)
    if (output / "conversion.json").exists():
        before = dataset_settings(output)
        if before != settings:
            raise ValueError(f"{str(output)!r} holds a dataset converted with other settings "
                             f"({before}); convert into another folder, or with those")
    output.mkdir(parents=True, exist_ok=True)
    summary = {"format": FORMAT, "settings": dataclasses.asdict(settings), "replays": [],
               "failed": []}
    jobs = [(p, str(output), settings, records) for p in paths]

    def record(done: int, result: dict) -> None:
        (summary["failed"] if "error" in result else summary["replays"]).append(result)
        write_json_atomic(output / "conversion.json", summary)
        state = ("already there" if result.get("skipped") else
                 f"not converted: {result['error']}" if "error" in result else
                 f"{result['records']} records")
        log(f"{done}/{len(paths)} {pathlib.Path(result['replay']).name}: {state}")

    if processes == 1:
        for done, job in enumerate(jobs, 1):
            record(done, _convert_one(job))
        return summary
    # Spawned, not forked: the parent may hold JAX's threads.
    with multiprocessing.get_context("spawn").Pool(processes) as pool:
        for done, result in enumerate(pool.imap_unordered(_convert_one, jobs), 1):
            record(done, result)
    return summary


def summary_line(summary: dict, output: str | os.PathLike, seconds: float) -> str:
    """One line on a conversion's summary (`convert_replays`' return)."""
    records = sum(r["records"] or 0 for r in summary["replays"])
    return (f"{len(summary['replays'])} replays written or already there, "
            f"{len(summary['failed'])} not; {records} records written in {seconds:.0f} s; "
            f"see {output}/conversion.json")


def read_shard(shard: str | os.PathLike, fields: dict, chunk: int = 256) -> Iterator[dict]:
    """The records of one shard in order (`decode`d with `fields`), read `chunk` at a
    time."""
    from array_record.python.array_record_module import ArrayRecordReader

    reader = ArrayRecordReader(str(shard))
    try:
        for start in range(0, reader.num_records(), chunk):
            for data in reader.read(start, min(start + chunk, reader.num_records())):
                yield decode(data, fields)
    finally:
        reader.close()


def shards(output: str | os.PathLike, split: str) -> list[str]:
    """The shards of a split, sorted."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; allowed: {list(SPLITS)}")
    return sorted(str(p) for p in (pathlib.Path(output) / split).glob(f"*{SHARD_SUFFIX}"))


def loader(output: str | os.PathLike, split: str, *, batch_size: int = 64, seed: int = 0,
           drop_remainder: bool = False):
    """A Grain dataset of minibatches drawn uniformly across every record of a split
    (shuffled with `seed`), each a dict of arrays with a leading batch axis (the last
    one smaller, unless `drop_remainder`).

    Raises:
      ValueError: for an unknown split, a split without shards, or a bad batch size.
    """
    import grain

    check_positive_int("batch_size", batch_size)
    paths = shards(output, split)
    if not paths:
        raise ValueError(f"no shards of split {split!r} under {str(output)!r}")
    fields = schema(dataset_settings(output))
    source = grain.sources.ArrayRecordDataSource(paths)
    return (grain.MapDataset.source(source).shuffle(seed=seed)
            .map(functools.partial(decode, fields=fields))
            .batch(batch_size, drop_remainder=drop_remainder))


def read_summary(output: str | os.PathLike) -> dict:
    """`conversion.json` of a dataset directory."""
    return json.loads((pathlib.Path(output) / "conversion.json").read_text())


def dataset_settings(output: str | os.PathLike) -> Settings:
    """The settings a dataset was converted with.

    Raises:
      ValueError: for a folder without `conversion.json`, or a dataset of another
        record format.
    """
    try:
        summary = read_summary(output)
    except (FileNotFoundError, NotADirectoryError):
        raise ValueError(f"{str(output)!r} is not a converted dataset (no conversion.json); "
                         f"make one with python -m sc2jax.experiments.convert_replays"
                         ) from None
    if summary.get("format") != FORMAT:
        raise ValueError(f"{str(output)!r} holds records of format {summary.get('format')}, "
                         f"this sc2jax reads format {FORMAT}; convert the replays again")
    return Settings(**summary["settings"])
