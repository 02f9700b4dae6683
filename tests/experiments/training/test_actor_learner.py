"""The actor, the compiled loop and the split loop (tiny, fast settings; the training
runs are in test_training.py, in a file of their own so that test workers share the load)."""

from __future__ import annotations

import dataclasses
import json
import threading

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import make
from sc2jax.environment.interface import narrow
from sc2jax.environment.sc2api.controller import Controller
from sc2jax.environment.sc2api.game_env import GameEnv, GameEnvBatch
from sc2jax.environment.server import Sc2ApiServer
from sc2jax.experiments.reporting.metrics_log import read_csv
from sc2jax.experiments.training import trainer
from sc2jax.experiments.training.actor import make_unroll
from sc2jax.experiments.training.checkpoints import placed_as_restored
from sc2jax.experiments.training.compiled_loop import make_train_chunk
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.device_actor import DeviceActor
from sc2jax.experiments.training.host_actor import HostActor, run_split_loop
from sc2jax.experiments.training.learner import OptimiserConfig, make_learner
from sc2jax.networks import policy
from sc2jax.networks.unroll import unroll as network_unroll

from .test_training import TINY


@pytest.fixture(scope="module")
def agent():
    return trainer.build(TINY)


def _initial_state(agent, seed: int, rates=None):
    """A fresh state placed as `trainer.train` places it (`placed_as_restored`), so that
    the programs these tests compile are those of test_training's runs of TINY (one
    persistent-cache entry each; an uncommitted state compiles another program)."""
    if rates is None:
        return placed_as_restored(agent.initial_state(jax.random.PRNGKey(seed)))
    keys = jax.random.split(jax.random.PRNGKey(seed), len(rates))
    return placed_as_restored(jax.vmap(agent.initial_state)(keys, rates))


@pytest.mark.slow
def test_unroll_emits_a_consistent_trajectory(agent):
    k, b = TINY.unroll_length, TINY.num_envs
    unroll = make_unroll(agent.sim, agent.core, k)
    state = _initial_state(agent, 0)
    actor, traj, episodes = jax.jit(unroll.unroll)(state.learner.params, state.actor)
    assert traj.observation["feature_screen"].shape == (k + 1, b, 2, 16, 16)
    assert traj.observation["feature_minimap"].dtype == jnp.uint8  # Packed into bytes.
    assert traj.action.function.shape == traj.reward.shape == (k, b)
    assert traj.first.shape == (k + 1, b) and bool(traj.first[0].all())
    assert episodes.ended.shape == (k, b)
    # The next unroll starts where this one ended.
    last = jax.tree.map(lambda x: x[-1], traj.observation)
    for key, layers in zip(narrow.LAYER_KEYS, (agent.sim.fmt.screen_layers,
                                                agent.sim.fmt.minimap_layers)):
        np.testing.assert_array_equal(narrow.unpacked(last, key, layers),
                                      actor.timestep.observation[key])
    # The behaviour log-probability is the network's log-probability of the action.
    out = jax.jit(lambda params, obs: network_unroll(agent.network, params, obs))(
        state.learner.params, jax.tree.map(lambda x: x[:k], traj.observation))
    log_pi = policy.log_prob(out, traj.action, traj.observation["available_actions_mask"][:k])
    np.testing.assert_allclose(traj.behaviour_log_prob, log_pi.total, rtol=1e-4, atol=1e-4)
    # Every action was available where it was taken.
    available = np.asarray(traj.observation["available_actions_mask"][:k])
    chosen = np.take_along_axis(available, np.asarray(traj.action.function)[..., None], -1)
    assert chosen.all()


@pytest.mark.slow
def test_scan_and_loop_chunks_agree_and_learn(agent):
    unroll = make_unroll(agent.sim, agent.core, TINY.unroll_length)
    state = _initial_state(agent, 1)
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


@pytest.mark.slow
def test_a_pipelined_chunk_acts_one_update_behind(agent):
    unroll = make_unroll(agent.sim, agent.core, TINY.unroll_length)
    state = _initial_state(agent, 3)
    act, update = jax.jit(unroll.unroll), jax.jit(agent.learner.update)
    # By hand: batches 1 and 2 acted with the first parameters, batch 3 with those after
    # one update; each learnt in turn.
    actor, batch1, episodes1 = act(state.learner.params, state.actor)
    actor, batch2, episodes2 = act(state.learner.params, actor)
    learner, _ = update(state.learner, batch1)
    actor, batch3, episodes3 = act(learner.params, actor)
    learner, _ = update(learner, batch2)
    learner, last = update(learner, batch3)
    close = lambda a, b: np.testing.assert_allclose(a, b, rtol=2e-4, atol=1e-6)  # noqa: E731
    for scan in (False, True):
        chunk = make_train_chunk(unroll, agent.learner, 3, scan=scan, pipelined=True)
        out, metrics, episodes = chunk(jax.tree.map(jnp.array, state))  # donated
        assert int(out.learner.update) == 3 and metrics["loss"].shape == (3,)
        jax.tree.map(close, out.learner.params, learner.params)
        close(metrics["loss"][2], last["loss"])
        jax.tree.map(np.testing.assert_array_equal, episodes,
                     jax.tree.map(lambda *e: np.stack(e), episodes1, episodes2, episodes3))
        np.testing.assert_array_equal(out.actor.key, actor.key)
    # The plain chunk acts batch 2 with the parameters after one update, the hand-made
    # reference above with the first ones: matching the reference tells the two apart.
    with pytest.raises(ValueError, match="needs updates_per_chunk >= 2, got 1"):
        make_train_chunk(unroll, agent.learner, 1, pipelined=True)


@pytest.mark.slow
def test_non_point_rate_scale_scales_all_but_the_point_heads(agent):
    unroll = make_unroll(agent.sim, agent.core, TINY.unroll_length)
    state = _initial_state(agent, 2)
    _, traj, _ = jax.jit(unroll.unroll)(state.learner.params, state.actor)
    scaled = trainer.build(dataclasses.replace(TINY, non_point_rate_scale=0.25)).learner
    deltas = []
    for learner in (agent.learner, scaled):
        new, _ = jax.jit(learner.update)(state.learner, traj)
        deltas.append(jax.tree.map(lambda a, b: np.asarray(a) - np.asarray(b),
                                   new.params["params"], state.learner.params["params"]))
    full, quarter = deltas
    # The spatial heads take the same step; every other parameter a quarter of it.
    jax.tree.map(np.testing.assert_array_equal, full["point_heads"], quarter["point_heads"])
    assert any(np.any(d != 0) for d in jax.tree.leaves(full["point_heads"]))
    for name in ("fc", "value", "function", "screen_conv"):
        # (Deltas of float32 parameters near 0.01 are rounded to about 1e-9.)
        jax.tree.map(lambda a, b: np.testing.assert_allclose(b, 0.25 * a, rtol=1e-5,
                                                             atol=3e-8),
                     full[name], quarter[name])
        assert any(np.any(d != 0) for d in jax.tree.leaves(full[name])), name
    # A network without point heads is refused, not scaled all over.
    ar = trainer.build(dataclasses.replace(TINY, agent="arfullyconv"))
    no_heads = make_learner(ar.network, lambda params, traj: (0.0, {}),
                            OptimiserConfig(non_point_rate_scale=0.5))
    with pytest.raises(ValueError, match="needs a network with `point_heads`; ARFullyConv"):
        no_heads.init(jax.random.PRNGKey(0), state.actor.timestep.observation, 1e-3)


@pytest.mark.slow
def test_sweep_chunk_trains_each_run_as_if_alone(agent):
    unroll = make_unroll(agent.sim, agent.core, TINY.unroll_length)
    rates = jnp.array([1e-4, 1e-3], jnp.float32)
    states = _initial_state(agent, 2, rates)
    outs = {}
    for scan in (False, True):  # one run after another (CPU's default), and vmapped
        chunk = make_train_chunk(unroll, agent.learner, 2, num_runs=2, scan=scan)
        outs[scan] = chunk(jax.tree.map(jnp.array, states))  # the chunk donates its input
        _, metrics, episodes = outs[scan]
        assert metrics["learning_rate"].shape == (2, 2)
        np.testing.assert_allclose(metrics["learning_rate"][:, 0], [1e-4, 1e-3], rtol=1e-6)
        assert episodes.score.shape == (2, 2, TINY.unroll_length, 2)
    alone, _, _ = make_train_chunk(unroll, agent.learner, 2)(
        jax.tree.map(lambda x: jnp.array(x[1]), states))
    close = lambda a, b: np.testing.assert_allclose(a, b, rtol=2e-4, atol=1e-6)  # noqa: E731
    jax.tree.map(lambda a, b: close(a[1], b), outs[False][0].learner.params,
                 alone.learner.params)
    jax.tree.map(close, outs[False][0].learner.params, outs[True][0].learner.params)
    for r in (0, 1):  # the runs differ (their own rates and seeds)
        assert int(outs[False][0].learner.update[r]) == 2
    assert not np.allclose(outs[False][0].learner.params["params"]["value"]["kernel"][0],
                           outs[False][0].learner.params["params"]["value"]["kernel"][1])


@pytest.mark.slow
def test_split_loop_trains_from_a_dm_env_environment():
    config = TrainConfig(**{**TINY.to_json(), "off_policy_correction": "vtrace"})
    agent = trainer.build(config)
    env = make(config.map_name, screen_size=16, minimap_size=16,
               screen_features=config.screen_features,
               minimap_features=config.minimap_features, num_envs=2, seed=0)
    assert env.simulator.fmt == agent.sim.fmt
    actor = HostActor(env, agent.core, config.unroll_length)
    # Placed as `train` places it, so that the update is the program of the next test's.
    state = placed_as_restored(agent.initial_learner(jax.random.PRNGKey(3)))
    trajectory = actor.unroll(state.params)
    k = config.unroll_length
    assert trajectory.observation["feature_screen"].shape == (k + 1, 2, 2, 16, 16)
    assert trajectory.behaviour_log_prob.shape == trajectory.reward.shape == (k, 2)
    out = network_unroll(agent.network, state.params,
                         jax.tree.map(lambda x: x[:k], trajectory.observation))
    log_pi = policy.log_prob(out, trajectory.action,
                             trajectory.observation["available_actions_mask"][:k]).total
    np.testing.assert_allclose(trajectory.behaviour_log_prob, log_pi, rtol=1e-4, atol=1e-4)
    learner, metrics = run_split_loop(actor, agent.learner, state, 3)
    assert int(learner.update) == 3 and len(metrics) == 3
    assert all(np.isfinite(m["loss"]) for m in metrics)
    with pytest.raises(ValueError, match="num_updates"):
        run_split_loop(actor, agent.learner, state, 0)


@pytest.mark.slow  # About 13 s (its own programs): the fast tier stays under 3 minutes.
def test_a_device_actor_feeds_the_split_loop():
    config = TrainConfig(**{**TINY.to_json(), "off_policy_correction": "vtrace"})
    agent = trainer.build(config)
    k, device = config.unroll_length, jax.devices()[0]
    actor = DeviceActor(make_unroll(agent.sim, agent.core, k), 2, jax.random.PRNGKey(0),
                        device, learner_device=device)
    state = placed_as_restored(agent.initial_learner(jax.random.PRNGKey(3)))
    trajectory = actor.unroll(state.params)
    assert trajectory.observation["feature_screen"].shape == (k + 1, 2, 2, 16, 16)
    assert trajectory.reward.devices() == {device}
    # MoveToBeacon's timer ends both episodes after 240 agent steps.
    updates = 240 // k + 1
    learner, metrics = run_split_loop(actor, agent.learner, state, updates)
    assert int(learner.update) == updates and all(np.isfinite(m["loss"]) for m in metrics)
    assert len(actor.episode_returns) == 2 and min(actor.episode_returns) >= 0


@pytest.mark.slow
def test_training_on_games_over_the_sc2_api_resumes_and_evaluates(tmp_path):
    # Two simulator servers stand in for two game processes: `train` with backend "sc2"
    # acts for both with one batched policy (HostActor), feeds the V-trace learner
    # (SplitLoop), checkpoints the learner, resumes, and evaluates in the games.
    config = TrainConfig(**{**TINY.to_json(), "backend": "sc2", "eval_episodes": 3,
                            "off_policy_correction": "vtrace"})
    agent = trainer.build(config)
    assert agent.sim is None
    threads = []

    def games(cfg):
        assert cfg == config
        servers = [Sc2ApiServer(port=0) for _ in range(2)]
        for server in servers:
            threads.append(threading.Thread(target=server.serve_forever, daemon=True))
            threads[-1].start()
        # Episodes truncated at 48 game loops (6 agent steps), so some end in training.
        return GameEnvBatch([
            GameEnv(lambda server=server: Controller.connect("127.0.0.1", server.port),
                    cfg.map_name, screen_size=16, minimap_size=16,
                    screen_features=cfg.screen_features,
                    minimap_features=cfg.minimap_features, random_seed=seed,
                    game_steps_per_episode=48)
            for seed, server in enumerate(servers)])

    lines = []
    run_dir = str(tmp_path / "run")
    first = trainer.train(config, run_dir, progress=False, stop_after_updates=2,
                          games=games, log=lines.append)
    assert int(first.state.update) == 2 and first.evaluation is None
    result = trainer.train(config, run_dir, progress=False, games=games, log=lines.append)
    assert "Resumed from update 2 (16 agent steps)" in lines
    assert int(result.state.update) == 4
    rows = read_csv(str(tmp_path / "run" / "metrics.csv"))
    assert list(rows["update"]) == [2, 4] and np.isfinite(rows["loss"]).all()
    assert result.episode_scores.size >= 2  # Each game ended an episode in training.
    assert result.evaluation["episodes"] == 3
    assert json.loads((tmp_path / "run" / "eval.json").read_text())["episodes"] == 3
    for thread in threads:  # Every game was quit (a server stops on RequestQuit).
        thread.join(timeout=10)
        assert not thread.is_alive()
    _, params, meta = trainer.load_run(run_dir)
    assert meta["update"] == 4
    assert all(jax.tree.leaves(jax.tree.map(np.array_equal, params, result.state.params)))
