"""Demonstrations: simulator episodes written in the replay datasets' format, exact
(played again from the records, the simulator gives the same observations and score),
resumable, and cloned by supervised training into a policy that plays the mini-game."""

import json
import os

import jax
import numpy as np
import pytest

from sc2jax.environment import make
from sc2jax.environment.agents import scripted_policy
from sc2jax.environment.interface import narrow
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES
from sc2jax.replay_sl.dataset import dataset_settings, loader, read_shard, schema, shards
from sc2jax.replay_sl.demonstrations import Recording, batch_keys, record_demonstrations

RECORDING = Recording("MoveToBeacon", "scripted", seed=3, num_envs=2)


@pytest.fixture(scope="module")
def beacon():
    """The MoveToBeacon simulator at 16² and its scripted agent, as an `Act`."""
    sim = make("MoveToBeacon", 16, 16, 8, use_feature_units=True).simulator
    policy = scripted_policy("MoveToBeacon", sim.fmt)

    def act(key, carry, obs, first):
        return carry, jax.vmap(policy)(jax.random.split(key, first.shape[0]), obs)

    return sim, act


@pytest.mark.slow
def test_demonstrations_are_exact_and_resume(tmp_path, beacon):
    sim, act = beacon
    out = tmp_path / "demos"
    lines = []
    summary = record_demonstrations(sim, act, None, out, RECORDING, 3, log=lines.append)
    episodes = summary["replays"]
    assert [e["episode"] for e in episodes] == [0, 1, 2, 3]  # two whole batches
    assert not (out / ".partial").exists()
    fields = schema(dataset_settings(out))
    first = list(read_shard(episodes[0]["shard"], fields))
    assert len(first) == episodes[0]["records"] > 0
    # Played again from its records, episode 0 gives the same observations and score.
    step = jax.jit(lambda state, action, obs: sim.step(state, action, previous=obs))
    state, ts = jax.jit(sim.reset)(batch_keys(RECORDING, 0)[0][0])
    score = 0.0
    for t, record in enumerate(first):
        layers = narrow.unpack_observation(record, SCREEN_FEATURES, MINIMAP_FEATURES)
        for key in narrow.LAYER_KEYS:
            np.testing.assert_array_equal(layers[key], ts.observation[key])
        np.testing.assert_array_equal(record["available_actions_mask"],
                                      ts.observation["available_actions_mask"])
        assert record["game_loop"] == ts.observation["game_loop"][0] == 8 * t
        action = DenseAction(*(record[f"action_{name}"] for name in DenseAction._fields))
        assert record["available_actions_mask"][action.function]
        state, ts = step(state, action, ts.observation)
        score += float(ts.reward)
    assert ts.last() and score == episodes[0]["score"]
    # The value: above the batch's median score.
    for batch in (episodes[:2], episodes[2:]):
        median = np.median([e["score"] for e in batch])
        for e in batch:
            assert e["value"] == float(e["score"] > median)
            assert list(read_shard(e["shard"], fields))[0]["value"] == e["value"]
    # The loader serves them; a second run resumes; a lost shard is played again the same.
    batch = next(iter(loader(out, "train", batch_size=4)))
    assert batch["feature_screen"].shape == (4, 27, 16, 16)
    lost = episodes[3]["shard"]
    before = open(lost, "rb").read()
    os.remove(lost)
    lines.clear()
    again = record_demonstrations(sim, act, None, out, RECORDING, 4, log=lines.append)
    assert lines[0] == "batch 1/2: already there"
    assert open(lost, "rb").read() == before
    assert again["replays"] == episodes
    assert json.loads((out / "conversion.json").read_text())["recording"]["agent"] == "scripted"
    assert len(shards(out, "train")) + len(shards(out, "test")) == 4
    with pytest.raises(ValueError, match="holds another dataset"):
        record_demonstrations(sim, act, None, out, Recording("MoveToBeacon", "other", 3, 2), 2)


def test_bad_recordings_are_refused(tmp_path, beacon):
    sim, act = beacon
    with pytest.raises(ValueError, match="episodes must be a positive int, got 0"):
        record_demonstrations(sim, act, None, tmp_path, RECORDING, 0)
    few = make("MoveToBeacon", 16, 16, 8, screen_features=["player_relative"]).simulator
    with pytest.raises(ValueError, match="demonstrations record every feature layer"):
        record_demonstrations(few, act, None, tmp_path, RECORDING, 2)
