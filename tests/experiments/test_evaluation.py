"""Evaluation: policies by name, full episodes in one compiled call, the entry point's
flag checks, and the scripted agents playing their maps as a human would."""

import json
import subprocess
import sys

import numpy as np
import pytest

from sc2jax.environment import ObservationFormat, Simulator
from sc2jax.environment.agents import required_format, scripted_policy
from sc2jax.environment.environments import simulator
from sc2jax.experiments import evaluation

FMT = ObservationFormat(32, 32, **required_format("MoveToBeacon"))


def _sim(name="MoveToBeacon") -> Simulator:
    return simulator(name, FMT, 8, 0, 1.0, 1.0, False)


def test_unknown_agent_and_bad_counts_raise():
    with pytest.raises(ValueError, match="unknown agent 'dqn'"):
        evaluation.make_policy("dqn", _sim())
    policy = evaluation.make_policy("random", _sim())
    for kwargs in ({"episodes": 0}, {"episodes": 2, "num_envs": -1}):
        with pytest.raises(ValueError, match="must be a positive int"):
            evaluation.run_episodes(_sim(), policy, **{"episodes": 1, **kwargs})


def test_scripted_agent_needs_what_it_reads():
    with pytest.raises(ValueError, match="use_feature_units"):
        scripted_policy("MoveToBeacon", ObservationFormat(32, 32))
    with pytest.raises(ValueError, match=r"minimap layers \['visibility_map'\]"):
        scripted_policy("FindAndDefeatZerglings",
                        ObservationFormat(32, 32, minimap_features=("player_relative",
                                                                     "pathable")))
    with pytest.raises(ValueError, match="no scripted agent for map 'Nowhere'"):
        scripted_policy("Nowhere", FMT)


def test_scripted_move_to_beacon_plays_like_a_human():
    # A marine walks 2.25 units per game second: 270 units in the 120 s episode. Beacons
    # lie at least 5 (about 9 on average) apart, so walking straight from beacon to
    # beacon scores about 26 (the paper's DeepMind tester: 26, GrandMaster: 28); the
    # random policy scores about 1.
    stats = evaluation.run_episodes(_sim(), scripted_policy("MoveToBeacon", FMT), episodes=4,
                                    num_envs=4, seed=0)
    assert stats.scores.shape == (4,)
    assert (stats.steps == 240).all()  # The timer ends every episode: 1920 loops / 8.
    assert 20 <= stats.scores.mean() <= 32, stats.scores
    again = evaluation.run_episodes(_sim(), scripted_policy("MoveToBeacon", FMT), episodes=4,
                                    num_envs=4, seed=0)
    np.testing.assert_array_equal(stats.scores, again.scores)  # Same seed, same episodes.


def test_evaluate_rejects_bad_flags_before_compiling(tmp_path):
    out = subprocess.run([sys.executable, "-m", "sc2jax.experiments.evaluate", "--map=Nope"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode != 0
    assert "--map='Nope' is unknown; allowed:" in out.stderr
    out = subprocess.run([sys.executable, "-m", "sc2jax.experiments.evaluate",
                          "--episodes=0"], capture_output=True, text=True, timeout=120)
    assert out.returncode != 0 and "--episodes must be >= 1, got 0" in out.stderr


def test_evaluate_writes_json(tmp_path):
    path = tmp_path / "eval.json"
    out = subprocess.run(
        [sys.executable, "-m", "sc2jax.experiments.evaluate", "--map=MoveToBeacon",
         "--agent=random", "--episodes=2", "--num_envs=2", "--screen_size=16",
         "--minimap_size=16", f"--output={path}"],
        capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    result = json.loads(path.read_text())
    assert result["episodes"] == 2 and len(result["scores"]) == 2
    assert result["mean"] == pytest.approx(np.mean(result["scores"]))
    assert result["max"] == max(result["scores"])
    assert result["config"]["map"] == "MoveToBeacon"
    assert "Random policy" in out.stdout  # The paper's rows are printed beside.
