"""Supervised training on a replay dataset: the evaluation's measures by hand, and a
short run that checkpoints, resumes and reports."""

import json
import pathlib

import numpy as np
import pytest

from sc2jax.environment.interface.functions import FUNCTIONS, NUM_FUNCTIONS
from sc2jax.experiments.replay_training.config import (
    ReplayTrainConfig,
    default_learning_rate,
)
from sc2jax.experiments.replay_training.evaluation import LOOPS_PER_MINUTE, summarize

REPLAYS = pathlib.Path(__file__).parents[4] / "shared" / "replays"
TRAIN = REPLAYS / "asus_rog/0001_KairosJunction.SC2Replay"
TEST = REPLAYS / "nation_wars/0276_WorldofSleepers.SC2Replay"


def test_summarize_by_hand():
    # Four examples: function ranks 0, 3, 7, 0; values right, right, wrong, right; the
    # last two after 15 minutes; the second builds.
    move, build, attack = (FUNCTIONS[n].id for n in ("move_camera", "Build_Pylon_screen",
                                                     "Attack_screen"))
    available = np.zeros((4, NUM_FUNCTIONS), bool)
    available[:, [move, build, attack]] = True
    examples = {
        "function": np.asarray([0, 3, 7, 0]), "label": np.asarray([move, build, attack, move]),
        "build_rank": np.asarray([5, 0, 2, 1]),
        "screen": np.asarray([0, 1, 9, 0]), "uses_screen": np.asarray([0, 1, 1, 0], bool),
        "minimap": np.zeros(4, int), "uses_minimap": np.zeros(4, bool),
        "value_logit": np.asarray([1.0, -1.0, 1.0, 2.0]),
        "outcome": np.asarray([1.0, 0.0, 0.0, 1.0]),
        "game_loop": (np.asarray([1, 2, 15.5, 20]) * LOOPS_PER_MINUTE).astype(int),
        "label_available": np.asarray([1, 0, 1, 1], bool), "available": available}
    counts = np.zeros(NUM_FUNCTIONS, int)
    counts[[move, attack, build]] = [10, 5, 1]  # move_camera is the most frequent
    out = summarize(examples, counts)
    assert (out["action_top1"], out["action_top5"]) == (0.5, 0.75)
    assert (out["screen_top1"], out["screen_top5"]) == (0.0, 0.5)
    assert out["minimap_top1"] is None
    assert out["value_accuracy"] == 0.75 and out["value_after_15_min"] == 0.5
    assert out["value_by_minute"] == [[1, 1, 1.0], [2, 1, 1.0], [15, 1, 0.0], [20, 1, 1.0]]
    assert (out["build_top1"], out["build_top5"], out["build_examples"]) == (0.0, 1.0, 1)
    assert out["next_build_top1"] == 1.0  # Among the build commands alone: first.
    assert out["label_available"] == 0.75 and out["mean_available"] == 3
    # Majority: move_camera first, then Attack, then the Pylon: ranks 0, 2, 1, 0.
    assert out["majority_function"] == "move_camera"
    assert (out["majority_top1"], out["majority_top5"]) == (0.5, 1.0)


def test_bad_configs_are_refused():
    with pytest.raises(ValueError, match=r"unknown network 'fullyconv_lstm'; allowed: \["):
        ReplayTrainConfig("d", agent="fullyconv_lstm")
    with pytest.raises(ValueError, match="steps must be an int >= 0, got -1"):
        ReplayTrainConfig("d", steps=-1)
    assert [default_learning_rate(agent, size) for agent, size in (
        ("atari", 64), ("fullyconv", 32), ("fullyconv", 64), ("arfullyconv", 64))] == [
            1e-3, 1e-3, 1e-4, 1e-4]
    with pytest.raises(ValueError, match="learning_rate must be > 0, got 0"):
        ReplayTrainConfig("d", learning_rate=0)


@pytest.mark.slow
@pytest.mark.skipif(not TEST.exists(), reason="the replays are not there")
def test_a_run_trains_checkpoints_resumes_and_reports(tmp_path):
    import jax

    from sc2jax.experiments.replay_training.trainer import _Batches, train_replays
    from sc2jax.replay_sl.dataset import Settings, convert_replays
    from sc2jax.replay_sl.learner import to_batch

    data = tmp_path / "data"
    with pytest.raises(ValueError, match="is not a converted dataset"):
        train_replays(ReplayTrainConfig(str(data)), str(tmp_path / "run"))
    summary = convert_replays([str(TRAIN), str(TEST)], data,
                              Settings(screen_size=16, minimap_size=16, max_steps=48),
                              log=lambda _: None)
    assert sorted(r["split"] for r in summary["replays"]) == ["test", "train"]
    config = ReplayTrainConfig(str(data), agent="atari", steps=4, batch_size=16, log_every=2,
                               eval_every=2, eval_batches=2, final_eval_batches=4,
                               checkpoint_every=2)
    batches = _Batches(config)  # Read ahead on threads, in order, across an epoch's end.
    per = batches.per_epoch
    want = [to_batch(batches.epoch_data(s // per)[s % per]) for s in range(per - 1, per + 2)]
    got = list(batches.iterate(per - 1, per + 2))
    assert len(got) == 3
    for a, b in zip(want, got, strict=True):
        jax.tree.map(np.testing.assert_array_equal, a, b)
    run = tmp_path / "run"
    first = train_replays(config, str(run), progress=False, log=lambda _: None)
    assert first["updates"] == 4 and first["examples"] == 64
    assert json.loads((run / "config.json").read_text())["learning_rate"] == 1e-3  # Resolved.
    more = train_replays(ReplayTrainConfig(**{**config.__dict__, "steps": 6}), str(run),
                         progress=False, log=lambda _: None)
    assert more["updates"] == 6
    lines = (run / "test.csv").read_text().splitlines()
    assert [line.split(",")[0] for line in lines] == ["step", "0", "2", "4", "6"]
    assert (run / "curves.png").stat().st_size > 1000
    saved = json.loads((run / "eval.json").read_text())
    for name in ("action_top1", "value_accuracy", "majority_top1", "value_by_minute"):
        assert saved[name] is not None, name
    assert 0 < saved["label_available"] <= 1 and saved["train_samples_per_second"] > 0
    with pytest.raises(ValueError, match="is a file; give a directory"):
        train_replays(config, str(run / "config.json"), progress=False, log=lambda _: None)
    with pytest.raises(ValueError, match="holds a run with another config"):
        train_replays(ReplayTrainConfig(**{**config.__dict__, "agent": "fullyconv"}),
                      str(run), progress=False, log=lambda _: None)
