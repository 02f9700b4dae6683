"""Recorded episodes: saved, loaded, and replayed bit for bit."""

import numpy as np
import pytest

from sc2jax.environment.episodes import (
    Episode,
    EpisodeError,
    check_replay,
    load_episode,
    replay,
    save_episode,
)
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.experiments.training import evaluation
from tests.environment.helpers import SMALL, small_sim


def _episode(steps=3, **fields):
    actions = DenseAction(*(np.zeros((steps, 2) if name in ("screen", "minimap", "screen2")
                                     else (steps,), np.int32) for name in DenseAction._fields))
    values = dict(map_name="MoveToBeacon", screen_size=(32, 32), minimap_size=(32, 32),
                  step_mul=8, key=np.uint32([0, 7]), actions=actions,
                  rewards=np.float32([0, 1, 0][:steps]), agent="test")
    values.update(fields)
    return Episode(**values)


def test_an_episode_file_holds_what_was_saved(tmp_path):
    episode = _episode(score_index=0, game_steps_per_episode=960)
    save_episode(tmp_path / "a.npz", episode)
    loaded = load_episode(tmp_path / "a.npz")
    for name in ("map_name", "screen_size", "minimap_size", "step_mul", "agent",
                 "score_index", "score_multiplier", "game_steps_per_episode"):
        assert getattr(loaded, name) == getattr(episode, name), name
    np.testing.assert_array_equal(loaded.key, episode.key)
    np.testing.assert_array_equal(loaded.rewards, episode.rewards)
    for a, b in zip(loaded.actions, episode.actions):
        np.testing.assert_array_equal(a, b)
    assert loaded.score == 1.0 and loaded.num_steps == 3


def test_bad_files_and_values_get_clear_errors(tmp_path):
    with pytest.raises(EpisodeError, match="no episode file"):
        load_episode(tmp_path / "missing.npz")
    (tmp_path / "text.npz").write_text("not an archive")
    with pytest.raises(EpisodeError, match="not a NumPy .npz archive"):
        load_episode(tmp_path / "text.npz")
    (tmp_path / "corrupt.npz").write_bytes(b"PK\x03\x04 not a zip")
    with pytest.raises(EpisodeError, match="not a readable episode file"):
        load_episode(tmp_path / "corrupt.npz")
    np.savez(tmp_path / "other.npz", format=np.str_("something-else"))
    with pytest.raises(EpisodeError, match="format"):
        load_episode(tmp_path / "other.npz")
    save_episode(tmp_path / "good.npz", _episode())
    data = (tmp_path / "good.npz").read_bytes()
    (tmp_path / "truncated.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(EpisodeError, match="truncated.npz"):
        load_episode(tmp_path / "truncated.npz")
    with pytest.raises(ValueError, match="unknown map|Unknown map|NoSuchMap"):
        _episode(map_name="NoSuchMap")
    with pytest.raises(ValueError, match="leading axis"):
        _episode(rewards=np.float32([0, 1]))


@pytest.mark.slow
def test_a_recorded_episode_replays_bit_for_bit(tmp_path):
    sim = small_sim("CollectMineralShards")
    core = evaluation.policy_core(evaluation.make_policy("random", sim.map_name, SMALL))
    episodes = evaluation.record_episodes(sim, core, None, 2, seed=3, agent="random")
    assert [e.num_steps for e in episodes] == [240, 240]
    stats = evaluation.run_core_episodes(sim, core, None, 2, num_envs=2, seed=3)
    assert [e.score for e in episodes] == stats.scores.tolist()
    save_episode(tmp_path / "e.npz", episodes[1])
    loaded = load_episode(tmp_path / "e.npz")
    # Replayed with every layer (the recording's format had three fewer things drawn):
    # the layers do not change the game.
    states, timesteps = replay(loaded)
    check_replay(loaded, timesteps)
    assert np.asarray(timesteps.step_type)[-1] == 2  # LAST.
    assert np.asarray(states.game_loop)[-1] == 240 * 8
    # A changed action changes the episode, and the check sees it.
    moved = loaded.actions.screen.copy()
    moved[:, :] = 0
    changed = Episode(**{**loaded.__dict__, "actions": loaded.actions._replace(screen=moved)})
    with pytest.raises(AssertionError, match="differ"):
        check_replay(changed, replay(changed)[1])
