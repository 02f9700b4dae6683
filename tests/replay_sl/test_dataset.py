"""Replays converted into ArrayRecord shards, resumed after an interruption, and loaded
as minibatches."""

import pathlib

import numpy as np
import pytest

from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.replay_sl import dataset
from sc2jax.replay_sl.dataset import Settings, convert_replays, decode, loader, shards, split_of

REPLAYS = pathlib.Path(__file__).parents[3] / "shared" / "replays"
if not REPLAYS.is_dir():
    pytest.skip(f"the replays are not at {REPLAYS}", allow_module_level=True)
KAIROS = REPLAYS / "asus_rog/0001_KairosJunction.SC2Replay"  # player 1 won
SLEEPERS = REPLAYS / "nation_wars/0241_WorldofSleepers.SC2Replay"  # player 2 won
QUICK = Settings(screen_size=32, minimap_size=32, max_steps=12)


def test_conversion_writes_each_players_steps_and_skips_a_bad_replay(tmp_path):
    corrupt = tmp_path / "corrupt.SC2Replay"
    corrupt.write_bytes(b"not a replay" * 100)
    missing = tmp_path / "missing.SC2Replay"
    summary = convert_replays([str(KAIROS), str(corrupt), str(missing), str(SLEEPERS)],
                              tmp_path / "out", QUICK, log=lambda _: None)
    assert [r["records"] for r in summary["replays"]] == [24, 24]  # 2 players x 12 steps
    assert [f["replay"] for f in summary["failed"]] == [str(corrupt), str(missing)]
    assert "not a readable replay archive" in summary["failed"][0]["error"]
    assert "cannot read the file" in summary["failed"][1]["error"]
    assert dataset.read_summary(tmp_path / "out") == summary
    # Both games are in the training split (their SHA-1s are not 0 modulo 10).
    assert [r["split"] for r in summary["replays"]] == ["train", "train"]
    assert len(shards(tmp_path / "out", "train")) == 2

    batch = loader(tmp_path / "out", "train", batch_size=8, seed=0)[0]
    assert batch["feature_screen"].shape == (8, 27, 32, 32)
    assert batch["feature_minimap"].shape == (8, 11, 32, 32)
    assert batch["action_screen"].shape == (8, 2) and batch["player"].shape == (8, 11)
    assert set(np.unique(batch["value"]).tolist()) <= {0.0, 1.0}
    # Every record of the Kairos shard: the first 12 steps of player 1 (who won), then of
    # player 2; step 0 of each is a camera move (no action is earlier).
    from array_record.python.array_record_module import ArrayRecordReader
    reader = ArrayRecordReader(summary["replays"][0]["shard"])
    records = [decode(r, dataset.schema(QUICK)) for r in reader.read_all()]
    assert len(records) == 24
    assert [float(r["value"]) for r in records] == [1.0] * 12 + [0.0] * 12
    assert [int(r["game_loop"]) for r in records[:3]] == [0, 8, 16]
    assert int(records[0]["action_function"]) == FUNCTIONS.move_camera.id
    # available_actions: always no_op and the camera; select_larva for the Zerg (player
    # 2, with larvae from the start), never for the Terran.
    mask = np.stack([r["available_actions_mask"] for r in records])
    assert mask[:, [FUNCTIONS.no_op.id, FUNCTIONS.move_camera.id]].all()
    larva = mask[:, FUNCTIONS.select_larva.id]
    assert not larva[:12].any() and larva[12:].all()


def test_records_round_trip_and_a_wrong_record_is_refused():
    fields = dataset.schema(QUICK)
    record = {name: (np.arange(int(np.prod(shape))).reshape(shape) % 3).astype(dtype)
              for name, (dtype, shape) in fields.items()}
    back = decode(dataset.encode(record, fields), fields)
    assert all(np.array_equal(back[k], record[k]) and back[k].dtype == record[k].dtype
               for k in fields)
    with pytest.raises(ValueError, match=r"record field 'player' must have shape \(11,\)"):
        dataset.encode({**record, "player": np.zeros(3)}, fields)
    with pytest.raises(ValueError, match="does not match the dataset's schema"):
        decode(b"\0" * 10, fields)


def test_a_conversion_resumes_and_an_interrupted_shard_is_not_kept(tmp_path):
    out = tmp_path / "out"
    real = dataset.replay_records

    def interrupted(path, settings):
        for n, record in enumerate(real(path, settings)):
            if n == 5:
                raise KeyboardInterrupt
            yield record

    with pytest.raises(KeyboardInterrupt):
        convert_replays([str(KAIROS)], out, QUICK, log=lambda _: None, records=interrupted)
    assert shards(out, "train") == [] and not list((out / "train").iterdir())
    first = convert_replays([str(KAIROS)], out, QUICK, log=lambda _: None)
    again = convert_replays([str(KAIROS), str(SLEEPERS)], out, QUICK, log=lambda _: None)
    assert first["replays"][0]["records"] == 24 and not first["replays"][0]["skipped"]
    assert [r["skipped"] for r in again["replays"]] == [True, False]
    with pytest.raises(ValueError, match="converted with other settings"):
        convert_replays([str(KAIROS)], out, Settings(max_steps=3), log=lambda _: None)


def test_a_dataset_of_another_format_is_refused(tmp_path):
    (tmp_path / "conversion.json").write_text('{"settings": {}, "replays": [], "failed": []}')
    with pytest.raises(ValueError, match="holds records of format None, this sc2jax reads "
                                         "format 3; convert the replays again"):
        dataset.dataset_settings(tmp_path)
    with pytest.raises(ValueError, match="is not a converted dataset"):
        dataset.dataset_settings(tmp_path / "nowhere")


def test_the_split_and_bad_arguments():
    assert split_of("0" * 40) == "test" and split_of("1" * 40) == "train"
    assert split_of(format(10 * 12345, "040x")) == "test"
    with pytest.raises(ValueError, match="unknown split 'dev'"):
        shards("/nowhere", "dev")
    with pytest.raises(ValueError, match="no shards of split 'test'"):
        loader("/nowhere", "test")
    with pytest.raises(ValueError, match="max_steps must be a positive int or None, got 0"):
        Settings(max_steps=0)


@pytest.mark.slow
def test_a_small_supervised_run_beats_chance(tmp_path):
    # Atari-net on 400 steps of two games (both players, 16²), 120 Adam steps on the
    # loader's minibatches of 32. Chance: function top-5 5/573; value 1/2 (each game has a
    # winner and a loser, and the player vector names the player).
    import jax

    from sc2jax.environment.interface.specs import ObservationFormat
    from sc2jax.networks import make_network
    from sc2jax.replay_sl.learner import init, make_evaluate, make_update, to_batch

    settings = Settings(screen_size=16, minimap_size=16, max_steps=100)
    convert_replays([str(KAIROS), str(SLEEPERS)], tmp_path, settings, log=lambda _: None)
    batches = loader(tmp_path, "train", batch_size=32, seed=0)
    network = make_network("atari", ObservationFormat(screen_size=16, minimap_size=16))
    state = init(network, to_batch(batches[0]), jax.random.PRNGKey(0))
    # The full minibatches, and the update compiled at XLA's full optimisation (the suite
    # compiles at level 0, tests/conftest.py): 120 steps take 3 s instead of 100.
    full = [batch for batch in map(to_batch, batches) if batch.action.function.shape == (32,)]
    update = jax.jit(make_update(network, learning_rate=1e-3)).lower(state, full[0]).compile(
        compiler_options={"xla_backend_optimization_level": 3,
                          "xla_cpu_use_fusion_emitters": True})
    before = make_evaluate(network)(state.params, to_batch(batches[0]))
    for i in range(120):
        state, _ = update(state, full[i % len(full)])
    after = make_evaluate(network)(state.params, to_batch(batches[0]))
    assert float(after["loss"]) < 0.5 * float(before["loss"])
    assert float(after["action_top5"]) > 0.5 and float(after["value_accuracy"]) > 0.8
