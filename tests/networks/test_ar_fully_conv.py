"""arFullyConv: arguments are conditioned on the function id and earlier arguments."""

import functools

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.networks import act, log_prob
from tests.networks.helpers import BATCH, jitted_apply, network, random_obs

SELECT_RECT = 3  # select_rect(select_add, screen, screen2)
MOVE_SCREEN = 331  # Move_screen(queued, screen)


def _action(function, screen=(0, 0)):
    zeros = DenseAction(*(jnp.zeros((BATCH, 2) if i in (1, 2, 3) else (BATCH,), jnp.int32)
                          for i in range(14)))
    return zeros._replace(function=jnp.full((BATCH,), function, jnp.int32),
                          screen=jnp.tile(jnp.asarray(screen, jnp.int32), (BATCH, 1)))


@functools.cache
def _sample_and_score():
    """One compiled program: sample, then score the sample two ways."""
    net, _ = network("arfullyconv")

    def run(params, key, obs):
        action, out = act(net, params, key, obs)
        forced = net.apply(params, obs, action)
        available = obs["available_actions_mask"]
        return (action, log_prob(out, action, available).total,
                log_prob(forced, action, available).total)

    return jax.jit(run)


def test_function_id_changes_argument_distributions():
    net, params = network("arfullyconv")
    obs = random_obs(6)
    a = jitted_apply("arfullyconv")(params, obs, _action(SELECT_RECT))
    b = jitted_apply("arfullyconv")(params, obs, _action(MOVE_SCREEN))
    # Same state: value and function logits do not depend on the conditioning.
    np.testing.assert_allclose(a.value, b.value, atol=1e-6)
    np.testing.assert_allclose(a.function_logits, b.function_logits, atol=1e-6)
    # The screen distribution's shape (not only an offset) changes with a⁰.
    pa = jax.nn.softmax(a.argument_logits.screen.logits)
    pb = jax.nn.softmax(b.argument_logits.screen.logits)
    assert np.abs(pa - pb).max() > 1e-4


def test_earlier_argument_changes_later_ones():
    net, params = network("arfullyconv")
    obs = random_obs(6)
    a = jitted_apply("arfullyconv")(params, obs, _action(SELECT_RECT, screen=(1, 2)))
    b = jitted_apply("arfullyconv")(params, obs, _action(SELECT_RECT, screen=(14, 9)))
    # screen comes before screen2 in TYPES order: screen2 is conditioned on screen ...
    p2a = jax.nn.softmax(a.argument_logits.screen2.logits)
    p2b = jax.nn.softmax(b.argument_logits.screen2.logits)
    assert np.abs(p2a - p2b).max() > 1e-4
    # ... but screen itself is not conditioned on its own value.
    np.testing.assert_allclose(a.argument_logits.screen.logits, b.argument_logits.screen.logits,
                               atol=1e-6)


def test_sampling_matches_teacher_forcing():
    net, params = network("arfullyconv")
    obs = random_obs(7)
    action, sampled, forced = _sample_and_score()(params, jax.random.key(3), obs)
    assert bool(jnp.all(obs["available_actions_mask"][jnp.arange(BATCH), action.function]))
    # The logits the sample was drawn from are the teacher-forced ones for that action.
    np.testing.assert_allclose(sampled, forced, rtol=1e-4)
