"""The acme-style actor-critic loss factory on real (tiny) networks."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.losses import Trajectory, make_actor_critic_loss
from tests.networks.helpers import BATCH, network, random_action, seq_obs

T = 2


def _trajectory(name, function_ids=None):
    obs = seq_obs(11, T + 1)
    action = random_action(12, obs["available_actions_mask"][:T])
    if function_ids is not None:  # every action a no_op: no argument is used
        action = DenseAction(jnp.zeros_like(action.function), *action.arguments)
    first = jnp.zeros((T + 1, BATCH), bool).at[1, 0].set(True)
    carry = network(name)[0].initial_carry(BATCH) if name == "fullyconv_lstm" else None
    return Trajectory(obs, action, reward=jnp.ones((T, BATCH)),
                      discount=jnp.full((T, BATCH), 0.99), first=first,
                      behaviour_log_prob=jnp.full((T, BATCH), -3.0), initial_carry=carry)


def test_unused_argument_heads_get_no_gradient():
    net, params = network("fullyconv")
    loss_fn = make_actor_critic_loss(net)
    grads, metrics = jax.jit(jax.grad(loss_fn, has_aux=True))(params, _trajectory("fullyconv", 0))
    assert np.isfinite(metrics["loss"]) and set(metrics) >= {
        "policy_loss", "value_loss", "entropy_loss", "function_entropy", "advantage"}
    # A fresh network's screen policy is near-uniform over the pixels (used or not).
    pixels = np.prod(_trajectory("fullyconv", 0).observation["feature_screen"].shape[-2:])
    assert np.log(pixels) - 0.5 < metrics["screen_entropy"] <= np.log(pixels) + 1e-4
    heads = grads["params"]["heads"]
    for name in ("point_heads", "scalar_heads"):
        for leaf in jax.tree.leaves(heads[name]):
            assert float(jnp.abs(leaf).max()) == 0.0, name
    assert float(jnp.abs(heads["function"]["kernel"]).max()) > 0.0
    assert float(jnp.abs(heads["value"]["kernel"]).max()) > 0.0


def test_recurrent_network_with_vtrace():
    net, params = network("fullyconv_lstm")
    traj = _trajectory("fullyconv_lstm")
    loss_fn = jax.jit(make_actor_critic_loss(net, off_policy_correction="vtrace"))
    loss, metrics = loss_fn(params, traj)
    assert np.isfinite(loss) and np.isfinite(metrics["value_target"])
    # The log-probs it scores are those of the network's own outputs.
    assert metrics["log_prob"] < 0


def test_reward_scale_multiplies_the_rewards():
    net, params = network("fullyconv")
    traj = _trajectory("fullyconv")
    scaled = jax.jit(make_actor_critic_loss(net, reward_scale=0.25))(params, traj)
    by_hand = jax.jit(make_actor_critic_loss(net))(
        params, traj._replace(reward=traj.reward * 0.25))
    np.testing.assert_allclose(scaled[0], by_hand[0], rtol=1e-6)
    assert not np.isclose(scaled[0], jax.jit(make_actor_critic_loss(net))(params, traj)[0])


def test_bad_settings():
    net, _ = network("fullyconv")
    with pytest.raises(ValueError, match=r"unknown off_policy_correction 'retrace'.*'vtrace'"):
        make_actor_critic_loss(net, off_policy_correction="retrace")
