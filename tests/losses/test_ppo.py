"""PPO: GAE targets and the clipped surrogate on hand-worked numbers; on a real network
its first pass is A3C's gradient, and the learner's passes and minibatches."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.experiments.training.learner import OptimiserConfig, _minibatch, make_learner
from sc2jax.losses import (
    gae_targets,
    make_actor_critic_loss,
    make_ppo_targets,
    ppo_loss,
    truncated_returns,
)
from sc2jax.networks import policy
from sc2jax.networks.unroll import unroll
from tests.losses.test_learner_loss import _trajectory
from tests.networks.helpers import network

R, D, V = jnp.array([1.0, 2.0, 3.0]), jnp.array([0.9, 0.0, 0.9]), jnp.array([0.5, 1.0, 2.0])


def test_gae_spans_one_step_td_to_n_step_returns():
    advantage, target = gae_targets(V, R, D, 10.0, lambda_=1.0)
    np.testing.assert_allclose(advantage, truncated_returns(R, D, 10.0) - V, rtol=1e-6)
    np.testing.assert_allclose(target, truncated_returns(R, D, 10.0), rtol=1e-6)
    advantage, _ = gae_targets(V, R, D, 10.0, lambda_=0.0)  # r + γ v(s') - v(s)
    np.testing.assert_allclose(advantage, [1 + 0.9 * 1 - 0.5, 2 - 1, 3 + 0.9 * 10 - 2],
                               rtol=1e-6)


def test_the_surrogate_clips_the_ratio():
    behaviour = jnp.log(jnp.array([0.5, 0.5, 0.5]))
    log_pi = jnp.log(jnp.array([0.8, 0.2, 0.55]))  # ratios 1.6, 0.4, 1.1
    advantage = jnp.array([1.0, -2.0, 1.0])
    zeros, used = jnp.zeros(3), jnp.zeros((3, 13), bool)

    def loss(log_pi):
        return ppo_loss(V, log_pi, behaviour, advantage, V, zeros, jnp.zeros((3, 13)), used,
                        clip_epsilon=0.2, value_weight=0.0, entropy_weight=0.0)

    out = loss(log_pi)
    # min(1.6 * 1, 1.2 * 1) = 1.2; min(0.4 * -2, 0.8 * -2) = -1.6; 1.1 inside the clip.
    np.testing.assert_allclose(out.policy_loss, -(1.2 - 1.6 + 1.1) / 3, rtol=1e-5)
    grad = jax.grad(lambda lp: loss(lp).loss)(log_pi)
    # Clipped samples give no gradient; the third gives -ratio * A / T.
    np.testing.assert_allclose(grad, [0.0, 0.0, -1.1 / 3], rtol=1e-5, atol=1e-7)


def test_ppo_first_pass_at_lambda_one_is_the_a3c_gradient():
    net, params = network("fullyconv")
    a3c = make_actor_critic_loss(net)
    ppo = make_actor_critic_loss(net, off_policy_correction="ppo")
    trajectory = _trajectory("fullyconv")
    # The behaviour policy is the network itself: every ratio is 1.
    out = jax.jit(lambda p: unroll(net, p, trajectory.observation, jax.tree.map(
        lambda x: jnp.concatenate([x, x[:1]]), trajectory.action), trajectory.first))(params)
    mask = trajectory.observation["available_actions_mask"][:-1]
    behaviour = policy.log_prob(jax.tree.map(lambda x: x[:-1], out), trajectory.action,
                                mask).total
    trajectory = jax.jit(make_ppo_targets(net, gae_lambda=1.0))(params, trajectory._replace(
        behaviour_log_prob=behaviour))
    grad_a3c = jax.jit(jax.grad(lambda p: a3c(p, trajectory)[0]))(params)
    grad_ppo = jax.jit(jax.grad(lambda p: ppo(p, trajectory)[0]))(params)
    for a, b in zip(jax.tree.leaves(grad_a3c), jax.tree.leaves(grad_ppo)):
        np.testing.assert_allclose(a, b, rtol=2e-4, atol=1e-6)


@pytest.mark.slow
def test_the_learner_takes_epochs_times_minibatches_steps():
    net, params = network("fullyconv_lstm")
    trajectory = _trajectory("fullyconv_lstm")
    # Minibatch 1 of 2 holds environments 1, 3, ...: here environment 1 of 2.
    half = _minibatch(trajectory, jnp.int32(1), 2)
    np.testing.assert_array_equal(half.reward, trajectory.reward[:, 1:2])
    np.testing.assert_array_equal(half.observation["feature_screen"],
                                  trajectory.observation["feature_screen"][:, 1:2])
    assert jax.tree.leaves(half.initial_carry)[0].shape[0] == 1
    loss = make_actor_critic_loss(net, off_policy_correction="ppo")
    config = OptimiserConfig(anneal_updates=10)
    one, four = (make_learner(net, loss, config, prepare=make_ppo_targets(net), epochs=e,
                              minibatches=m) for e, m in ((1, 1), (2, 2)))
    obs = jax.tree.map(lambda x: x[0], trajectory.observation)
    results = []
    for learner in (one, four):
        state = learner.init(jax.random.PRNGKey(0), obs, 1e-3)
        state, metrics = jax.jit(learner.update)(state, trajectory)
        assert int(state.update) == 1 and np.isfinite(metrics["loss"])
        results.append(state.params)
    moved = [np.abs(np.asarray(b) - np.asarray(a)).max() > 0 for a, b in zip(
        jax.tree.leaves(results[0]), jax.tree.leaves(results[1]))]
    assert any(moved)  # Four steps land elsewhere than one.
