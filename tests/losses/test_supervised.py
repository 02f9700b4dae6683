"""The supervised value/policy loss of §5, Table 2 metrics, and a tiny fit."""

import jax
import jax.numpy as jnp
import numpy as np
import optax

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.losses import SupervisedBatch, make_supervised_loss, supervised_metrics
from sc2jax.networks import ArgumentLogits, NetworkOutput, PixelLogits, XYLogits
from tests.networks.helpers import SPEC, network, random_action, random_obs


def _hand_case():
    """Two examples at 4x4-pixel screen/minimap heads (the metric reads only these)."""
    # Function logits: id 7 > 5 > 4 > 3 > 2 > 1 > 0 (logit = -id except 7 = +1).
    fl = jnp.tile(-jnp.arange(573.0), (2, 1)).at[:, 7].set(1.0)
    available = jnp.ones((2, 573), bool).at[1, 7].set(False)  # 7 unavailable in example 1
    screen = PixelLogits(jnp.tile(jnp.arange(16.0), (2, 1)), width=4)  # pixel 15 best
    minimap = XYLogits(jnp.tile(jnp.arange(4.0), (2, 1)), jnp.zeros((2, 4)))
    args = [screen, minimap, screen] + [jnp.zeros((2, s[0])) for s in SPEC.argument_sizes[3:]]
    out = NetworkOutput(jnp.array([2.0, -1.0]), fl, ArgumentLogits(*args))
    zeros = [jnp.zeros((2, 2) if i < 3 else (2,), jnp.int32) for i in range(13)]
    # Example 0: select_point (2) at screen (x=3, y=3) = pixel 15; example 1: move_camera
    # (1) to minimap (x=0, y=0).
    action = DenseAction(jnp.array([2, 1]), jnp.array([[3, 3], [0, 0]]),
                         jnp.array([[0, 0], [0, 0]]), *zeros[2:])
    return out, action, available


def test_table2_metrics_hand_worked():
    out, action, available = _hand_case()
    m = jax.jit(supervised_metrics)(out, action, available, jnp.array([1.0, 1.0]))
    # Example 0: ids 7, 0, 1 beat id 2 -> rank 3: top-5 only. Example 1: 7 is masked,
    # id 0 beats id 1 -> rank 1: top-5 only.
    np.testing.assert_allclose([m["action_top1"], m["action_top5"]], [0.0, 1.0])
    # Screen: only example 0 uses it; pixel 15 has the highest logit -> top-1.
    np.testing.assert_allclose([m["screen_top1"], m["screen_top5"]], [1.0, 1.0])
    # Minimap: only example 1; x = 0 has the lowest x-logit: the 12 points with x > 0
    # beat (0, 0) -> neither top-1 nor top-5.
    np.testing.assert_allclose([m["minimap_top1"], m["minimap_top5"]], [0.0, 0.0])
    # Value logits [2, -1] predict [win, loss]; outcomes [win, win] -> 1/2.
    np.testing.assert_allclose(m["value_accuracy"], 0.5)


def test_tiny_supervised_fit_drives_the_loss_down():
    net, params = network("atari")
    obs = random_obs(21, (4,))
    batch = SupervisedBatch(obs, random_action(22, obs["available_actions_mask"]),
                            outcome=jnp.array([1.0, 0.0, 1.0, 0.0]))
    loss_fn = make_supervised_loss(net, value_weight=1.0)
    opt = optax.adam(1e-3)

    @jax.jit
    def update(params, opt_state):
        (loss, metrics), grads = jax.value_and_grad(loss_fn, has_aux=True)(params, batch)
        updates, opt_state = opt.update(grads, opt_state)
        return optax.apply_updates(params, updates), opt_state, loss, metrics

    opt_state = opt.init(params)
    losses = []
    for _ in range(15):
        params, opt_state, loss, metrics = update(params, opt_state)
        losses.append(float(loss))
    assert losses[-1] < 0.5 * losses[0], losses
    assert set(metrics) >= {"value_loss", "policy_loss", "action_top1", "screen_top5",
                            "minimap_top1", "value_accuracy"}
