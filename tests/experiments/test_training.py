"""The actor, the learner, the compiled loop and training runs (tiny, fast settings)."""

from __future__ import annotations

import json
import os
import threading

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import make
from sc2jax.environment.controller import Controller
from sc2jax.environment.game_env import GameEnv, GameEnvBatch
from sc2jax.environment.server import Sc2ApiServer
from sc2jax.experiments import evaluation, trainer
from sc2jax.experiments import sweeping as sampling
from sc2jax.experiments.actor import make_unroll
from sc2jax.experiments.compiled_loop import make_train_chunk
from sc2jax.experiments.config import TrainConfig, parse_names
from sc2jax.experiments.host_actor import HostActor, run_split_loop
from sc2jax.experiments.learner import annealed_learning_rate
from sc2jax.experiments.metrics_log import read_csv
from sc2jax.experiments.random_search import random_search
from sc2jax.losses.learner_loss import unroll as network_unroll
from sc2jax.networks import policy

TINY = TrainConfig(map_name="MoveToBeacon", agent="atari", screen_size=16, minimap_size=16,
                   screen_features=("player_relative", "selected"),
                   minimap_features=("player_relative",), num_envs=2, unroll_length=4,
                   total_steps=32, updates_per_chunk=2, eval_episodes=0,
                   checkpoint_interval_s=1e9)


@pytest.fixture(scope="module")
def agent():
    return trainer.build(TINY)


@pytest.mark.parametrize("change, message", [
    (dict(map_name="Nope"), "unknown map 'Nope'"),
    (dict(agent="lstm"), "unknown agent 'lstm'"),
    (dict(num_envs=0), "num_envs must be a positive int"),
    (dict(unroll_length=-1), "unroll_length must be a positive int"),
    (dict(learning_rate=0.0), "learning_rate must be a positive number"),
    (dict(discount=1.5), r"discount must be in \[0, 1\]"),
    (dict(screen_size=8), "screen_size"),
    (dict(screen_features=("nope",)), "nope"),
    (dict(off_policy_correction="retrace"), "unknown off_policy_correction"),
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


def test_unroll_emits_a_consistent_trajectory(agent):
    unroll = make_unroll(agent.sim, agent.core, 6)
    state = agent.initial_state(jax.random.PRNGKey(0))
    actor, traj, episodes = jax.jit(unroll.unroll)(state.learner.params, state.actor)
    k, b = 6, TINY.num_envs
    assert traj.observation["feature_screen"].shape == (k + 1, b, 2, 16, 16)
    assert traj.action.function.shape == traj.reward.shape == (k, b)
    assert traj.first.shape == (k + 1, b) and bool(traj.first[0].all())
    assert episodes.ended.shape == (k, b)
    # The next unroll starts where this one ended.
    np.testing.assert_array_equal(traj.observation["feature_screen"][-1],
                                  actor.timestep.observation["feature_screen"])
    # The behaviour log-probability is the network's log-probability of the action.
    out = network_unroll(agent.network, state.learner.params,
                         jax.tree.map(lambda x: x[:k], traj.observation))
    log_pi = policy.log_prob(out, traj.action, traj.observation["available_actions"][:k])
    np.testing.assert_allclose(traj.behaviour_log_prob, log_pi.total, rtol=1e-4, atol=1e-4)
    # Every action was available where it was taken.
    available = np.asarray(traj.observation["available_actions"][:k])
    chosen = np.take_along_axis(available, np.asarray(traj.action.function)[..., None], -1)
    assert chosen.all()


def test_scan_and_loop_chunks_agree_and_learn(agent):
    unroll = make_unroll(agent.sim, agent.core, TINY.unroll_length)
    state = agent.initial_state(jax.random.PRNGKey(1))
    before = jax.tree.map(np.asarray, state.learner.params)
    outs = []
    for scan in (True, False):
        chunk = make_train_chunk(unroll, agent.learner, 2, scan=scan)
        fresh = jax.tree.map(jnp.array, state)  # the chunk donates its input
        outs.append(chunk(fresh))
    (s1, m1, e1), (s2, m2, e2) = outs
    assert m1["loss"].shape == (2,) and e1.ended.shape == (2, TINY.unroll_length, 2)
    assert int(s1.learner.update) == 2
    jax.tree.map(lambda a, b: np.testing.assert_allclose(a, b, rtol=2e-4, atol=1e-6),
                 s1.learner.params, s2.learner.params)
    # The torso, the value and the function head learn (argument heads of functions
    # never taken get no gradient).
    for name in ("fc", "value", "function", "screen_conv"):
        changed = jax.tree.map(lambda a, b: bool(np.any(a != np.asarray(b))),
                               before["params"][name], s1.learner.params["params"][name])
        assert all(jax.tree.leaves(changed)), name


def test_sweep_chunk_vmaps_over_runs(agent):
    unroll = make_unroll(agent.sim, agent.core, TINY.unroll_length)
    rates = jnp.array([1e-4, 1e-3], jnp.float32)
    states = jax.vmap(agent.initial_state)(jax.random.split(jax.random.PRNGKey(2), 2), rates)
    chunk = make_train_chunk(unroll, agent.learner, 2, num_runs=2)
    states, metrics, episodes = chunk(states)
    assert metrics["learning_rate"].shape == (2, 2)
    np.testing.assert_allclose(metrics["learning_rate"][:, 0], [1e-4, 1e-3], rtol=1e-6)
    assert episodes.score.shape == (2, 2, TINY.unroll_length, 2)


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


def test_trained_run_can_be_evaluated(tmp_path):
    run = str(tmp_path / "run")
    result = trainer.train(TINY, run, log=lambda _: None, progress=False)
    agent, params, meta = trainer.load_run(run)
    assert meta["env_steps"] == TINY.total_updates * TINY.steps_per_update
    jax.tree.map(np.testing.assert_array_equal, params, result.state.learner.params)
    stats = evaluation.run_core_episodes(agent.sim, agent.core, params, 2, num_envs=2)
    assert stats.scores.shape == (2,) and (stats.steps > 0).all()
    with pytest.raises(FileNotFoundError, match="not a run directory"):
        trainer.load_run(str(tmp_path / "missing"))


def test_sampled_learning_rates_are_log_uniform_in_range():
    rates = sampling.sample_learning_rates(jax.random.PRNGKey(0), 2000, 1e-5, 1e-3)
    assert rates.shape == (2000,) and rates.min() >= 1e-5 and rates.max() <= 1e-3
    # log-uniform: a third of the mass in each factor of 10^(2/3).
    assert np.mean(np.log10(rates) < -13 / 3) == pytest.approx(1 / 3, abs=0.04)
    with pytest.raises(ValueError, match="lr_min <= lr_max"):
        sampling.sample_learning_rates(jax.random.PRNGKey(0), 2, 1e-3, 1e-5)


def test_sweep_reports_table1_entries(tmp_path):
    config = TrainConfig(**{**TINY.to_json(), "eval_episodes": 2})
    summary = sampling.run_sweep(config, [1e-4, 1e-3], str(tmp_path), log=lambda _: None)
    assert len(summary["run_scores"]) == 2 and summary["best_run"] in (0, 1)
    assert summary["best_mean"] == max(summary["run_scores"])
    assert summary["mean_over_runs"] == pytest.approx(np.mean(summary["run_scores"]))
    for name in ("sweep.json", "curves.csv", "learning_curves.png", "checkpoints"):
        assert os.path.exists(tmp_path / name), name


def test_random_search_keeps_the_best_policy():
    result = random_search(TINY, 3, episodes=2, policies_per_batch=2, log=lambda _: None)
    assert len(result["policy_means"]) == 3
    assert result["best_mean"] == max(result["policy_means"])
    assert result["max"] >= result["best_mean"]
    with pytest.raises(ValueError, match="temperature must be > 0"):
        random_search(TINY, 1, temperature=0.0)


def test_split_loop_trains_from_a_dm_env_environment():
    config = TrainConfig(**{**TINY.to_json(), "off_policy_correction": "vtrace"})
    agent = trainer.build(config)
    env = make(config.map_name, screen_size=16, minimap_size=16,
               screen_features=config.screen_features,
               minimap_features=config.minimap_features, num_envs=2, seed=0)
    assert env.simulator.fmt == agent.sim.fmt
    actor = HostActor(env, agent.core, config.unroll_length)
    state = agent.initial_state(jax.random.PRNGKey(3))
    trajectory = actor.unroll(state.learner.params)
    k = config.unroll_length
    assert trajectory.observation["feature_screen"].shape == (k + 1, 2, 2, 16, 16)
    assert trajectory.behaviour_log_prob.shape == trajectory.reward.shape == (k, 2)
    out = network_unroll(agent.network, state.learner.params,
                         jax.tree.map(lambda x: x[:k], trajectory.observation))
    log_pi = policy.log_prob(out, trajectory.action,
                             trajectory.observation["available_actions"][:k]).total
    np.testing.assert_allclose(trajectory.behaviour_log_prob, log_pi, rtol=1e-4, atol=1e-4)
    learner, metrics = run_split_loop(actor, agent.learner, state.learner, 3)
    assert int(learner.update) == 3 and len(metrics) == 3
    assert all(np.isfinite(m["loss"]) for m in metrics)
    with pytest.raises(ValueError, match="num_updates"):
        run_split_loop(actor, agent.learner, state.learner, 0)


def test_split_loop_trains_from_games_over_the_sc2_api():
    # Two simulator servers stand in for two game processes; one batched policy acts
    # for both, and their trajectories feed the learner.
    config = TrainConfig(**{**TINY.to_json(), "off_policy_correction": "vtrace"})
    agent = trainer.build(config)
    servers = [Sc2ApiServer(port=0) for _ in range(2)]
    for server in servers:
        threading.Thread(target=server.serve_forever, daemon=True).start()
    games = GameEnvBatch([
        GameEnv(lambda server=server: Controller.connect("127.0.0.1", server.port),
                config.map_name, screen_size=16, minimap_size=16,
                screen_features=config.screen_features,
                minimap_features=config.minimap_features, random_seed=seed)
        for seed, server in enumerate(servers)])
    try:
        assert games.fmt == agent.sim.fmt
        actor = HostActor(games, agent.core, config.unroll_length)
        state = agent.initial_state(jax.random.PRNGKey(3))
        learner, metrics = run_split_loop(actor, agent.learner, state.learner, 2)
        assert int(learner.update) == 2 and all(np.isfinite(m["loss"]) for m in metrics)
        trajectory = actor.unroll(learner.params)
        k = config.unroll_length
        assert trajectory.observation["feature_screen"].shape == (k + 1, 2, 2, 16, 16)
        assert trajectory.observation["available_actions"].dtype == bool
    finally:
        games.close()
