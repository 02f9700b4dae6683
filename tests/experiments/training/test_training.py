"""Training configs and runs: resume, evaluation, sweeps and random search (tiny, fast
settings; the actor and the loops are in test_actor_learner.py)."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.engine.simulator import BLIZZARD_SCORE
from sc2jax.environment.interface.players import Difficulty
from sc2jax.experiments.reporting.metrics_log import read_csv
from sc2jax.experiments.sweeps import sweeping as sampling
from sc2jax.experiments.sweeps.random_search import over_policies, random_search
from sc2jax.experiments.training import evaluation, trainer
from sc2jax.experiments.training.checkpoints import Checkpointer
from sc2jax.experiments.training.config import TrainConfig, parse_names
from sc2jax.experiments.training.learner import annealed_learning_rate

pytestmark = pytest.mark.slow  # the slow tier: left out of `pytest -m "not slow"`

TINY = TrainConfig(map_name="MoveToBeacon", agent="atari", screen_size=16, minimap_size=16,
                   screen_features=("player_relative", "selected"),
                   minimap_features=("player_relative",), num_envs=2, unroll_length=4,
                   total_steps=32, updates_per_chunk=2, eval_episodes=0,
                   checkpoint_interval_s=1e9)
# 32 updates of 30-step episodes on CollectMineralShards, its best parameters chosen by
# an evaluation every 8 updates. Tests of single runs and sweeps derive their configs
# from it where they can, so that they share compiled programs (a sweep on the CPU runs
# the single run's update; the update depends on the number of updates, through the
# rate's annealing, and not on the evaluation settings).
PERIODIC = TrainConfig(**{**TINY.to_json(), "map_name": "CollectMineralShards",
                          "step_mul": 64, "total_steps": 256, "best_eval_interval": 8,
                          "best_eval_episodes": 2})
SWEEP = TrainConfig(**{**PERIODIC.to_json(), "eval_episodes": 2})


@pytest.mark.parametrize("change, message", [
    (dict(map_name="Nope"), "unknown map 'Nope'"),
    (dict(agent="lstm"), "unknown network 'lstm'"),
    (dict(num_envs=0), "num_envs must be a positive int"),
    (dict(unroll_length=-1), "unroll_length must be a positive int"),
    (dict(learning_rate=0.0), "learning_rate must be a positive number"),
    (dict(discount=1.5), r"discount must be in \[0, 1\]"),
    (dict(screen_size=8), "screen_size"),
    (dict(screen_features=("nope",)), "nope"),
    (dict(off_policy_correction="retrace"), "unknown off_policy_correction"),
    (dict(best_eval_interval=-1), "best_eval_interval must be an int >= 0, got -1"),
    (dict(best_eval_episodes=0), "best_eval_episodes must be a positive int"),
    (dict(non_point_rate_scale=0.0), "non_point_rate_scale must be a positive number"),
    (dict(reward_scale=-1.0), "reward_scale must be a positive number, got -1.0"),
    (dict(agent="arfullyconv", non_point_rate_scale=0.1), "needs a network with point heads"),
    (dict(backend="sc2", best_eval_interval=5), "best_eval_interval=5 needs backend"),
    (dict(ppo_epochs=0), "ppo_epochs must be a positive int"),
    (dict(ppo_minibatches=3), "num_envs=32 does not split into ppo_minibatches=3"),
    (dict(ppo_clip=1.0), r"ppo_clip must be in \(0, 1\), got 1.0"),
    (dict(gae_lambda=-0.1), r"gae_lambda must be in \[0, 1\], got -0.1"),
    (dict(actor_device=-1), "actor_device must be an int >= 0, got -1"),
    (dict(backend="sc2", actor_device=0), "actor_device=0 needs backend 'simulator'"),
    (dict(pipelined=1), "pipelined must be a bool, got 1"),
    (dict(pipelined=True, updates_per_chunk=1), r"updates_per_chunk >= 2 \(got 1\)"),
    (dict(pipelined=True, actor_device=0), r"no actor_device \(got 0;"),
    (dict(pipelined=True, backend="sc2"), r"needs backend 'simulator' \(got 'sc2'\)"),
    (dict(bot=("terran", "easy")), "bot plays the other player of a ladder map"),
    (dict(map_name="Acropolis", bot=("zerg", "easy")), "the simulator's computer is a Terran"),
    (dict(map_name="Acropolis", bot=("terran", "cheat_insane")), "the simulator's computer"),
    (dict(score_index=-3), r"score_index must be -2 \(the Blizzard score\), -1"),
    (dict(score_index=True), "score_index must be -2"),
    (dict(backend="sc2", score_index=-1), "score_index -1 needs backend 'simulator'"),
])
def test_config_rejects_bad_values(change, message):
    with pytest.raises(ValueError, match=message):
        TrainConfig(**change)


def test_config_json_roundtrip_and_layers():
    assert TrainConfig.from_json(json.loads(json.dumps(TINY.to_json()))) == TINY
    assert parse_names("all") is None and parse_names("a, b") == ("a", "b")
    assert TINY.steps_per_update == 8 and TINY.total_updates == 4
    with pytest.raises(ValueError, match="unknown config keys"):
        TrainConfig.from_json({"bogus": 1})


def test_a_ladder_map_config_plays_the_simulators_computer_for_its_reward():
    # The paper's full game: A3C against the easiest computer, rewarded by the outcome
    # (PySC2's default on ladder maps) or the Blizzard score.
    config = TrainConfig(map_name="Acropolis", bot=("terran", "very_easy"), screen_size=16,
                         minimap_size=16)
    assert config.reward_index() == -1 and TINY.reward_index() == 0
    sim = trainer.build(config).sim
    assert sim.computer == Difficulty.very_easy and sim.score_index == -1
    scored = dataclasses.replace(config, score_index=BLIZZARD_SCORE)
    assert trainer.build(scored).sim.score_index == BLIZZARD_SCORE
    assert trainer.build(dataclasses.replace(config, bot=None)).sim.computer == 0


def test_configs_that_differ_only_in_run_settings_share_their_programs():
    base = trainer.build(PERIODIC)
    other = trainer.build(TrainConfig(**{
        **PERIODIC.to_json(), "seed": 5, "learning_rate": 1e-2, "eval_episodes": 3,
        "best_eval_interval": 0, "best_eval_episodes": 4, "checkpoint_interval_s": 1.0}))
    assert other.config.seed == 5 and other.config.best_eval_episodes == 4
    assert other.sim is base.sim and other.core is base.core and other.learner is base.learner
    assert other.chunk() is base.chunk() and other.chunk(2) is base.chunk(2)
    # The number of updates is part of the update (its rate's annealing).
    longer = trainer.build(TrainConfig(**{**PERIODIC.to_json(), "total_steps": 512}))
    assert longer.learner is not base.learner and longer.chunk() is not base.chunk()


def test_learning_rate_anneals_linearly_to_half():
    # 1e-3 * (1 - 0.5 * 5/10) = 7.5e-4; after the anneal it stays at half.
    assert float(annealed_learning_rate(jnp.float32(1e-3), jnp.int32(5), 10)) == (
        pytest.approx(7.5e-4))
    assert float(annealed_learning_rate(jnp.float32(1e-3), jnp.int32(50), 10)) == (
        pytest.approx(5e-4))


def test_learning_rate_warms_up_linearly():
    # Update 1 of a 4-update warm-up uses 2/4 of the annealed rate 1e-3 * (1 - 0.5 / 10).
    assert float(annealed_learning_rate(jnp.float32(1e-3), jnp.int32(1), 10, 4)) == (
        pytest.approx(0.5 * 9.5e-4))
    assert float(annealed_learning_rate(jnp.float32(1e-3), jnp.int32(3), 10, 4)) == (
        pytest.approx(8.5e-4))
    with pytest.raises(ValueError, match="warmup_updates must be an int >= 0, got -1"):
        TrainConfig(warmup_updates=-1)


def test_train_with_the_actor_beside_the_learner_resumes_and_evaluates(tmp_path):
    config = TrainConfig(**{**TINY.to_json(), "actor_device": 0, "eval_episodes": 2,
                            "off_policy_correction": "vtrace"})
    run_dir = str(tmp_path / "split")
    first = trainer.train(config, run_dir, log=lambda _: None, progress=False,
                          stop_after_updates=2)
    assert int(first.state.update) == 2  # the learner's state alone is checkpointed
    resumed = trainer.train(config, run_dir, log=lambda _: None, progress=False)
    assert int(resumed.state.update) == config.total_updates
    assert resumed.evaluation["episodes"] == 2
    assert read_csv(os.path.join(run_dir, "metrics.csv"))["update"].tolist() == [2, 4]
    with pytest.raises(ValueError, match="actor_device=0 runs one learner on one device"):
        trainer.train(config, str(tmp_path / "x"), devices=2)
    with pytest.raises(ValueError, match="actor_device=7, but this process has"):
        trainer.train(TrainConfig(**{**config.to_json(), "actor_device": 7}),
                      str(tmp_path / "y"))


def test_train_resumes_exactly_where_it_stopped(tmp_path):
    straight = trainer.train(TINY, str(tmp_path / "a"), log=lambda _: None, progress=False)
    interrupted = str(tmp_path / "b")
    first = trainer.train(TINY, interrupted, log=lambda _: None, progress=False,
                          stop_after_updates=2)
    assert int(first.state.learner.update) == 2
    resumed = trainer.train(TINY, interrupted, log=lambda _: None, progress=False)
    assert int(resumed.state.learner.update) == TINY.total_updates
    jax.tree.map(np.testing.assert_array_equal, straight.state.learner.params,
                 resumed.state.learner.params)
    for name in ("metrics.csv", "episodes.csv"):
        a, b = read_csv(tmp_path / "a" / name), read_csv(os.path.join(interrupted, name))
        np.testing.assert_array_equal(a["step"], b["step"])
    for name in ("config.json", "learning_curve.png", "checkpoints", "tensorboard"):
        assert os.path.exists(os.path.join(interrupted, name)), name
    with pytest.raises(ValueError, match="another config"):
        trainer.train(TrainConfig(**{**TINY.to_json(), "learning_rate": 1e-2}), interrupted,
                      log=lambda _: None, progress=False)
    # A run started from another's last parameters (`init_from`: an A3C run here, a
    # replay-trained one in test_cloning) begins from them, and says so.
    source = str(tmp_path / "a")
    config = dataclasses.replace(TINY, init_from=source)
    jax.tree.map(np.testing.assert_array_equal, trainer.start_params(trainer.build(config)),
                 straight.state.learner.params)
    lines = []
    trainer.train(config, str(tmp_path / "c"), log=lines.append, progress=False)
    assert f"Starting from the parameters of {source}" in lines


@pytest.mark.slow
def test_a_pipelined_run_resumes_exactly_where_it_stopped(tmp_path):
    config = dataclasses.replace(TINY, pipelined=True, off_policy_correction="vtrace")
    straight = trainer.train(config, str(tmp_path / "a"), log=lambda _: None, progress=False)
    interrupted = str(tmp_path / "b")
    trainer.train(config, interrupted, log=lambda _: None, progress=False,
                  stop_after_updates=2)
    resumed = trainer.train(config, interrupted, log=lambda _: None, progress=False)
    assert int(resumed.state.learner.update) == config.total_updates
    jax.tree.map(np.testing.assert_array_equal, straight.state.learner.params,
                 resumed.state.learner.params)
    a, b = (read_csv(os.path.join(d, "metrics.csv")) for d in (tmp_path / "a", interrupted))
    np.testing.assert_array_equal(a["loss"], b["loss"])


def test_trained_run_can_be_evaluated(tmp_path):
    run = str(tmp_path / "run")
    result = trainer.train(TINY, run, log=lambda _: None, progress=False)
    agent, params, meta = trainer.load_run(run)
    assert meta["env_steps"] == TINY.total_updates * TINY.steps_per_update
    jax.tree.map(np.testing.assert_array_equal, params, result.state.learner.params)
    stats = evaluation.run_core_episodes(agent.sim, agent.core, params, 2, num_envs=2)
    assert stats.scores.shape == (2,) and (stats.steps > 0).all()
    # The command line's JSON names what it evaluated: the run's map and format, not
    # the flags' defaults (a random agent at 64x64). (It runs the program just compiled.)
    path = tmp_path / "eval.json"
    out = subprocess.run(
        [sys.executable, "-m", "sc2jax.experiments.evaluate", f"--run_dir={run}",
         "--episodes=2", "--num_envs=2", f"--output={path}"],
        capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    config = json.loads(path.read_text())["config"]
    assert config["agent"] == "atari" and config["screen_size"] == 16, config
    assert config["env_steps"] == meta["env_steps"] and config["run_dir"] == run
    with pytest.raises(FileNotFoundError, match="not a run directory"):
        trainer.load_run(str(tmp_path / "missing"))


def test_training_keeps_and_evaluates_its_best_parameters(tmp_path, monkeypatch):
    # Short episodes (30 agent steps at step_mul 64) and a window of one episode, so the
    # best recent score changes within a tiny run. It is interrupted after update 26 of
    # 32, and its best must survive the restart. (The run's programs are those of
    # PERIODIC's: the best-parameter settings change no compiled function.)
    monkeypatch.setattr(trainer, "SCORE_WINDOW", 1)
    config = TrainConfig(**{**PERIODIC.to_json(), "best_eval_interval": 0,
                            "eval_episodes": 2})
    run = str(tmp_path / "run")
    trainer.train(config, run, log=lambda _: None, progress=False, stop_after_updates=26)
    result = trainer.train(config, run, log=lambda _: None, progress=False)
    metrics = read_csv(os.path.join(run, "metrics.csv"))
    assert np.isfinite(metrics["score"]).sum() >= 4  # Episodes ended in several chunks.
    best = np.nanmax(metrics["score"])
    first = int(metrics["update"][np.flatnonzero(metrics["score"] == best)[0]])
    _, params, meta = trainer.load_run(run, best=True)
    assert meta == {"update": first, "env_steps": first * config.steps_per_update,
                    "score": best, "chosen_by": "training window"}
    assert jax.tree.structure(params) == jax.tree.structure(result.state.learner.params)
    if first == config.total_updates:  # The best are the final parameters.
        assert result.best_evaluation is None
    else:
        assert result.best_evaluation["episodes"] == 2
        assert result.best_evaluation["update"] == first
        with open(os.path.join(run, "eval_best.json")) as f:
            assert json.load(f)["score"] == best
    with pytest.raises(ValueError, match="not both"):
        trainer.load_run(run, step=2, best=True)


def test_a_run_without_a_full_window_has_no_best_parameters(tmp_path):
    run = str(tmp_path / "run")
    trainer.train(TINY, run, log=lambda _: None, progress=False)
    assert not os.path.exists(os.path.join(run, "best"))
    with pytest.raises(FileNotFoundError, match="has no best parameters"):
        trainer.load_run(run, best=True)


def test_best_parameters_chosen_by_periodic_evaluation(tmp_path):
    # Every 8 updates (chunks of 2) the current parameters play 2 evaluation episodes,
    # always with the same seed; the best of those are kept, across an interruption.
    # (On this map and seed the evaluations differ, and the best is before update 18.)
    config = PERIODIC
    run = str(tmp_path / "run")
    trainer.train(config, run, log=lambda _: None, progress=False, stop_after_updates=18)
    trainer.train(config, run, log=lambda _: None, progress=False)
    metrics = read_csv(os.path.join(run, "metrics.csv"))
    evaluated = np.isfinite(metrics["eval_score"])
    np.testing.assert_array_equal(metrics["update"][evaluated], [8, 16, 24, 32])
    best = np.max(metrics["eval_score"][evaluated])
    first = int(metrics["update"][np.flatnonzero(metrics["eval_score"] == best)[0]])
    agent, params, meta = trainer.load_run(run, best=True)
    assert meta == {"update": first, "env_steps": first * config.steps_per_update,
                    "score": best, "chosen_by": "evaluation"}
    assert first < 18 and len(set(metrics["eval_score"][evaluated])) > 1
    again = trainer.evaluate_params(agent, params, 2, seed=config.seed + 2)
    assert again.summary["mean"] == best


def test_sampled_learning_rates_are_log_uniform_in_range():
    rates = sampling.sample_learning_rates(jax.random.PRNGKey(0), 2000, 1e-5, 1e-3)
    assert rates.shape == (2000,) and rates.min() >= 1e-5 and rates.max() <= 1e-3
    # log-uniform: a third of the mass in each factor of 10^(2/3).
    assert np.mean(np.log10(rates) < -13 / 3) == pytest.approx(1 / 3, abs=0.04)
    with pytest.raises(ValueError, match="lr_min <= lr_max"):
        sampling.sample_learning_rates(jax.random.PRNGKey(0), 2, 1e-3, 1e-5)


def test_sweep_reports_table1_entries(tmp_path):
    config = TrainConfig(**{**SWEEP.to_json(), "best_eval_interval": 0})
    summary = sampling.run_sweep(config, [1e-4, 1e-3], str(tmp_path), log=lambda _: None)
    assert len(summary["run_scores"]) == 2 and summary["best_run"] in (0, 1)
    assert summary["best_mean"] == max(summary["run_scores"])
    assert summary["mean_over_runs"] == pytest.approx(np.mean(summary["run_scores"]))
    for name in ("sweep.json", "curves.csv", "learning_curves.png", "checkpoints"):
        assert os.path.exists(tmp_path / name), name
    assert not os.path.exists(tmp_path / "best") and "final_scores" not in summary


def test_sweep_keeps_each_runs_best_parameters_by_periodic_evaluation(tmp_path):
    config = SWEEP
    summary = sampling.run_sweep(config, [1e-3, 1e-2], str(tmp_path), log=lambda _: None)
    assert set(summary["best_updates"]) <= {8, 16, 24, 32}
    assert sampling.run_score_rule(config) == ("the mean of 2 fresh evaluation episodes of "
                                               "its best parameters by an evaluation of 2 "
                                               "episodes every 8 updates")
    assert len(summary["final_scores"]) == 2
    agent = trainer.build(config)
    with Checkpointer(tmp_path / "best", max_to_keep=1) as checkpointer:
        stacked, meta = checkpointer.restore(
            jax.eval_shape(lambda: jax.vmap(agent.initial_learner)(
                jax.random.split(jax.random.PRNGKey(0), 2))).params)
    assert meta == {"scores": summary["best_eval_scores"],
                    "updates": summary["best_updates"]}
    for r in range(2):
        params = jax.tree.map(lambda x, r=r: x[r], stacked)
        # The kept parameters are the ones that scored, and the run's score is theirs.
        assert trainer.best_eval_score(agent, params, config.seed + r) == (
            summary["best_eval_scores"][r])
        assert trainer.evaluate_params(agent, params, 2, seed=config.seed + r).summary[
            "mean"] == summary["run_scores"][r]


def test_random_search_keeps_the_best_policy():
    result = random_search(TINY, 3, episodes=2, policies_per_batch=2, log=lambda _: None)
    assert len(result["policy_means"]) == 3
    assert result["best_mean"] == max(result["policy_means"])
    assert result["max"] >= result["best_mean"]
    with pytest.raises(ValueError, match="temperature must be > 0"):
        random_search(TINY, 1, temperature=0.0)


def test_over_policies_pairs_each_policy_with_its_key():
    def fn(params, key):
        return params["w"] * 10.0 + jax.random.uniform(key)

    params = {"w": jnp.arange(3.0)}
    keys = jax.random.split(jax.random.PRNGKey(0), 3)
    expected = jnp.stack([fn({"w": params["w"][i]}, keys[i]) for i in range(3)])
    np.testing.assert_allclose(jax.jit(over_policies(fn))(params, keys), expected, rtol=1e-6)
