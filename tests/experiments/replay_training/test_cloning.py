"""The whole supervised pipeline on exact inputs: the scripted agent's MoveToBeacon
episodes recorded as a dataset, cloned by `train_replays`, the clone played on the
mini-game by `evaluate`, and A3C's first parameters taken from it with `init_from`."""

import dataclasses
import json
import subprocess
import sys

import jax
import numpy as np
import pytest

from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.pretrained import load_replay_run
from sc2jax.experiments.training.trainer import build, start_params, train

RANDOM_MEAN = 0.81
"""The random policy's MoveToBeacon mean (docs/results.md); the scripted agent's is 26."""


def _command(*args):
    out = subprocess.run([sys.executable, "-m", *args], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0 and "Traceback" not in out.stderr, out.stderr[-3000:]
    return out.stdout


@pytest.mark.slow
def test_a_cloned_scripted_agent_plays_and_starts_a3c(tmp_path):
    demos, clone = tmp_path / "demos", tmp_path / "clone"
    sizes = ("--screen_size=16", "--minimap_size=16")
    # Seed 1's eight episodes put episode 6 in the test split.
    _command("sc2jax.experiments.record_demonstrations", "--map=MoveToBeacon",
             "--agent=scripted", "--episodes=8", "--num_envs=8", "--seed=1", *sizes,
             f"--output={demos}")
    recorded = json.loads((demos / "conversion.json").read_text())
    assert [e["split"] for e in recorded["replays"]].count("test") == 1
    _command("sc2jax.experiments.train_replays", f"--dataset={demos}", "--network=fullyconv",
             "--steps=150", "--batch_size=32", "--eval_every=150", "--eval_batches=2",
             "--final_eval_batches=6", f"--run_dir={clone}")
    held_out = json.loads((clone / "eval.json").read_text())
    assert held_out["action_top1"] > 0.9  # The scripted agent moves: Move_screen.
    scores = tmp_path / "scores.json"
    _command("sc2jax.experiments.evaluate", f"--run_dir={clone}", "--map=MoveToBeacon",
             "--episodes=8", "--num_envs=8", f"--output={scores}")
    played = json.loads(scores.read_text())
    assert played["config"]["screen_size"] == 16 and played["config"]["replay_updates"] == 150
    assert played["mean"] > 10 * RANDOM_MEAN, played

    # A3C from the clone: its first parameters are the clone's (the run that starts from
    # them is test_training's, from an A3C run).
    config = TrainConfig(screen_size=16, minimap_size=16, num_envs=2, unroll_length=4,
                         total_steps=8, eval_episodes=0, init_from=str(clone))
    jax.tree.map(np.testing.assert_array_equal, start_params(build(config)),
                 load_replay_run(str(clone)).params)
    other = tmp_path / "atari"
    with pytest.raises(ValueError, match="do not fit this run's network"):
        train(dataclasses.replace(config, agent="atari"), str(other), progress=False,
              log=lambda _: None)
    assert not other.exists()  # Refused before anything was written.
