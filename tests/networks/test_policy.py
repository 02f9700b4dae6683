"""The composite policy distribution: hand-worked numbers, masking, unused arguments."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.networks import (
    ArgumentLogits,
    NetworkOutput,
    PixelLogits,
    XYLogits,
    entropy,
    log_prob,
    mode,
    policy,
    sample,
)
from tests.networks.helpers import SPEC

# Compiled once for all the tests below.
_LOG_PROB = jax.jit(log_prob)
_ENTROPY = jax.jit(entropy)
_SAMPLE = jax.jit(sample)
_MODE = jax.jit(mode)
_GRAD = jax.jit(jax.grad(lambda o, a, av: log_prob(o, a, av).total.sum()))

SELECT_POINT = 2  # select_point(select_point_act [4], screen)
MOVE_CAMERA = 1  # move_camera(minimap)


def _output(batch=1, xy=False, function_logits=None):
    """Zero logits everywhere (uniform heads) at the test spec's sizes, batch [batch]."""
    args = []
    for sizes in SPEC.argument_sizes:
        if len(sizes) == 2:
            x, y = jnp.zeros((batch, sizes[0])), jnp.zeros((batch, sizes[1]))
            args.append(XYLogits(x, y) if xy else PixelLogits(jnp.zeros((batch, x.shape[1] * 16)),
                                                              width=16))
        else:
            args.append(jnp.zeros((batch, sizes[0])))
    fl = jnp.zeros((batch, 573)) if function_logits is None else function_logits
    return NetworkOutput(jnp.zeros((batch,)), fl, ArgumentLogits(*args))


def _action(function, **args):
    base = {name: jnp.zeros((1, 2) if i < 3 else (1,), jnp.int32)
            for i, name in enumerate(DenseAction._fields[1:])}
    base.update({k: jnp.asarray([v], jnp.int32) for k, v in args.items()})
    return DenseAction(jnp.asarray([function], jnp.int32), *base.values())


def _available(*ids):
    return jnp.zeros((1, 573), bool).at[0, list(ids)].set(True)


def test_log_prob_hand_worked_pixels():
    # Available {0, 2}; logit of 2 is ln 3, so π(2) = 3 / (1 + 3) = 3/4.
    out = _output(function_logits=jnp.zeros((1, 573)).at[0, 2].set(np.log(3.0)))
    # Screen pixel (x=1, y=0) is index 0 * 16 + 1 = 1; its logit ln 255 gives
    # π = 255 / (255 * e^0 + 255) = 1/2 over the 256 pixels.
    screen = jnp.zeros((1, 256)).at[0, 1].set(np.log(255.0))
    out = out._replace(argument_logits=out.argument_logits._replace(
        screen=PixelLogits(screen, width=16)))
    lp = _LOG_PROB(out, _action(SELECT_POINT, select_point_act=3, screen=[1, 0]),
                   _available(0, 2))
    # select_point_act is uniform over 4: 1/4. Total: ln(3/4) + ln(1/4) + ln(1/2).
    np.testing.assert_allclose(lp.function, [np.log(0.75)], rtol=1e-6)
    np.testing.assert_allclose(lp.arguments[6], [np.log(0.25)], rtol=1e-6)
    np.testing.assert_allclose(lp.arguments[0], [np.log(0.5)], rtol=1e-5)
    np.testing.assert_allclose(lp.total, [np.log(0.75 * 0.25 * 0.5)], rtol=1e-5)
    # Arguments select_point does not take contribute exactly 0.
    assert all(float(lp.arguments[i][0]) == 0.0 for i in range(13) if i not in (0, 6))


def test_log_prob_and_entropy_hand_worked_xy():
    out = _output(xy=True)
    # x logits [0, ln 3, 0, ...] over 16: π(x=1) = 3 / (15 + 3) = 1/6; y uniform: 1/16.
    minimap = XYLogits(jnp.zeros((1, 16)).at[0, 1].set(np.log(3.0)), jnp.zeros((1, 16)))
    out = out._replace(argument_logits=out.argument_logits._replace(minimap=minimap))
    lp = _LOG_PROB(out, _action(MOVE_CAMERA, minimap=[1, 7]), _available(0, 1, 2, 3))
    # π(a⁰ = 1) = 1/4 (4 available, equal logits).
    np.testing.assert_allclose(lp.total, [np.log(0.25 / 6 / 16)], rtol=1e-5)
    ent = _ENTROPY(out, _available(0, 1, 2, 3))
    # Uniform over 4 available ids: ln 4. queued: uniform over 2: ln 2.
    np.testing.assert_allclose(ent.function, [np.log(4.0)], rtol=1e-6)
    np.testing.assert_allclose(ent.arguments[3], [np.log(2.0)], rtol=1e-6)
    # screen (XY, uniform): H(x) + H(y) = 2 ln 16.
    np.testing.assert_allclose(ent.arguments[0], [2 * np.log(16.0)], rtol=1e-6)




def test_unavailable_actions_are_never_sampled():
    n = 256
    rng = np.random.default_rng(0)
    available = jnp.asarray(rng.random((n, 573)) < 0.05).at[:, 0].set(True)
    # Huge logits on every id: unavailable ones must still get probability 0.
    out = _output(n, function_logits=jnp.full((n, 573), 50.0).at[:, 0].set(-50.0))
    action = _SAMPLE(jax.random.key(0), out, available, 1.0)
    assert bool(jnp.all(available[jnp.arange(n), action.function]))
    probs = jax.nn.softmax(policy.mask_function_logits(out.function_logits, available))
    assert float(jnp.max(jnp.where(available, 0.0, probs))) == 0.0
    np.testing.assert_allclose(probs.sum(-1), 1.0, rtol=1e-5)
    # Arguments the sampled function does not take are 0.
    used = policy.used_arguments(action.function)
    for i, value in enumerate(action.arguments):
        unused = ~used[:, i]
        assert not np.any(np.asarray(value)[np.asarray(unused)])
    assert action.function.dtype == jnp.int32 and action.screen.dtype == jnp.int32


def test_mode_and_low_temperature():
    n = 256  # the same shapes as the sampling test: no new compilation
    logits = jnp.zeros((n, 573)).at[:, 3].set(2.0).at[:, 2].set(1.0)
    out = _output(n, function_logits=logits)
    available = jnp.zeros((n, 573), bool).at[:, jnp.array([0, 2])].set(True)
    # 3 is the most likely id overall, but unavailable: the mode is 2.
    assert bool(jnp.all(_MODE(out, available).function == 2))
    # At temperature 1e-3 the logit gap of 1 between ids 2 and 0 becomes 1000.
    cold = _SAMPLE(jax.random.key(1), out, available, 1e-3)
    assert bool(jnp.all(cold.function == 2))
    with pytest.raises(ValueError, match="temperature must be > 0"):
        sample(jax.random.key(0), out, available, temperature=0.0)


def test_unused_arguments_get_no_gradient():
    out = _output()
    action = _action(SELECT_POINT, select_point_act=1, screen=[3, 4])

    grads = _GRAD(out, action, _available(0, 2)).argument_logits
    used = {0, 6}
    for i, g in enumerate(grads):
        norm = sum(float(jnp.abs(leaf).sum()) for leaf in jax.tree.leaves(g))
        assert (norm > 0) == (i in used), (i, norm)


def test_jit_and_no_jit_agree():
    out = _output(function_logits=jnp.linspace(-1, 1, 573)[None])
    action = _action(3, select_add=1, screen=[2, 5], screen2=[7, 9])
    eager = log_prob(out, action, _available(0, 2, 3))
    jitted = _LOG_PROB(out, action, _available(0, 2, 3))
    for a, b in zip(jax.tree.leaves(eager), jax.tree.leaves(jitted)):
        np.testing.assert_allclose(a, b, rtol=1e-6)


def test_bad_inputs():
    out = _output()
    with pytest.raises(TypeError, match="DenseAction"):
        log_prob(out, (0, 1), _available(0))
    with pytest.raises(ValueError, match="available_actions has shape"):
        log_prob(out, _action(0), jnp.ones((1, 10), bool))
