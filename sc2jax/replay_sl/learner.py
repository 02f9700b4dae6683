"""Supervised learning from a replay dataset: a dual-headed network's value and policy
trained on minibatches of `dataset.loader`, with `losses.make_supervised_loss`.

    state = init(network, to_batch(records), key, learning_rate=1e-3)
    update = make_update(network)
    state, metrics = update(state, to_batch(records))   # jitted

The function head is trained and measured under the records' `available_actions`
(`availability`), with the label's function added: the game accepted the player's
action, so it was available, whatever the approximate mask says.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from sc2jax.environment.interface.dense import DenseAction
from sc2jax.losses.supervised import SupervisedBatch, make_supervised_loss


class LearnerState(NamedTuple):
    params: Any
    opt_state: Any
    step: jax.Array


def to_batch(records: dict[str, np.ndarray]) -> SupervisedBatch:
    """A loader minibatch (dict of arrays with a leading batch axis) as a `SupervisedBatch`.

    The feature layers stay packed into bytes, as the dataset keeps them (0.29 of
    int32's bytes to copy to an accelerator): the networks read them as they are
    (`environment.interface.narrow`)."""
    action = DenseAction(*(records[f"action_{name}"].astype(np.int32)
                           for name in DenseAction._fields))
    available = records["available_actions_mask"].astype(bool)
    available[np.arange(len(available)), action.function] = True
    observation = {**{key: records[key] for key in records if key.startswith("feature_")},
                   "player": records["player"].astype(np.int32),
                   "available_actions_mask": available}
    return SupervisedBatch(observation, action, records["value"].astype(np.float32))


def _optimiser(learning_rate: float) -> optax.GradientTransformation:
    return optax.adam(learning_rate)


def init(network, batch: SupervisedBatch, key: jax.Array, *,
         learning_rate: float = 1e-3) -> LearnerState:
    """The network's parameters for `batch`'s shapes, and Adam's state."""
    if not learning_rate > 0:
        raise ValueError(f"learning_rate must be > 0, got {learning_rate!r}")
    one = jax.tree.map(lambda x: x[:1], batch)
    params = network.init(key, one.observation, one.action)
    return LearnerState(params, _optimiser(learning_rate).init(params), jnp.int32(0))


def make_update(network, *, learning_rate: float = 1e-3, value_weight: float = 1.0):
    """`update(state, batch) -> (state, metrics)`, jitted: one Adam step on the supervised
    loss; metrics are the paper's Table 2 accuracies of the batch before the step."""
    loss_fn = make_supervised_loss(network, value_weight=value_weight)
    optimiser = _optimiser(learning_rate)

    @jax.jit
    def update(state: LearnerState, batch: SupervisedBatch):
        (_, metrics), grads = jax.value_and_grad(loss_fn, has_aux=True)(state.params, batch)
        updates, opt_state = optimiser.update(grads, state.opt_state, state.params)
        return LearnerState(optax.apply_updates(state.params, updates), opt_state,
                            state.step + 1), metrics

    return update


def make_evaluate(network, *, value_weight: float = 1.0):
    """`evaluate(params, batch) -> metrics`, jitted, without a step."""
    loss_fn = make_supervised_loss(network, value_weight=value_weight)
    return jax.jit(lambda params, batch: loss_fn(params, batch)[1])
