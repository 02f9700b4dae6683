"""A3C on PySC2's raw interface: the raw network acts through the compiled actor, and the
learner's loss reads its raw actions."""

import dataclasses

import jax
import numpy as np
import pytest

from sc2jax.experiments.training import trainer
from sc2jax.experiments.training.actor import function_mask
from sc2jax.experiments.training.checkpoints import placed_as_restored
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.networks import raw_policy
from sc2jax.networks.unroll import unroll as network_unroll

from .test_training import TINY

RAW = dataclasses.replace(TINY, agent="raw_fullyconv", max_units=8, unroll_length=8)


@pytest.mark.slow
def test_a_raw_agent_acts_and_learns_from_its_raw_actions():
    agent = trainer.build(RAW)
    assert agent.sim.fmt.action_space == "raw" and agent.sim.fmt.raw_resolution == (16, 16)
    state = placed_as_restored(agent.initial_state(jax.random.PRNGKey(0)))
    chunk = agent.chunk()
    after, metrics, episodes = chunk(jax.tree.map(np.array, state))
    assert int(after.learner.update) == RAW.updates_per_chunk
    assert np.isfinite(metrics["loss"]).all()
    # The unroll's behaviour log-probabilities are the network's, under the raw policy.
    traj = jax.jit(agent._unroll().unroll)(state.learner.params, state.actor)[1]
    t = RAW.unroll_length
    out = network_unroll(agent.network, state.learner.params,
                         jax.tree.map(lambda x: x[:t], traj.observation))
    log_pi = raw_policy.log_prob(out, traj.action,
                                 traj.observation["available_actions_mask"][:t])
    np.testing.assert_allclose(traj.behaviour_log_prob, log_pi.total, rtol=1e-4, atol=1e-4)
    assert traj.observation["raw_units"].shape == (t + 1, RAW.num_envs, 8, 46)
    assert traj.action.units.shape == (t, RAW.num_envs, 8)
    # The commanding rows' head learnt from the actions that named units.
    changed = jax.tree.map(lambda a, b: bool(np.any(np.asarray(a) != np.asarray(b))),
                           state.learner.params["params"]["unit_logits"],
                           after.learner.params["params"]["unit_logits"])
    assert all(jax.tree.leaves(changed))


def test_raw_settings_are_checked():
    assert function_mask(["no_op", "Move_pt"], raw=True).sum() == 2
    with pytest.raises(ValueError, match="unknown raw function 'Move_screen'"):
        dataclasses.replace(RAW, functions=("no_op", "Move_screen"))
    with pytest.raises(ValueError, match="needs backend 'simulator'"):
        TrainConfig(agent="raw_fullyconv", backend="sc2")
    with pytest.raises(ValueError, match="max_units must be a positive int"):
        dataclasses.replace(RAW, max_units=0)
