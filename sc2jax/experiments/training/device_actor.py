"""An actor on a device of its own, beside the learner: acting and learning overlap.

    actor = DeviceActor(make_unroll(sim, core, K), num_envs, key, jax.devices()[1],
                        learner_device=jax.devices()[0])
    state, metrics = run_split_loop(actor, learner, state, num_updates)

The compiled loop (`compiled_loop`) acts and then learns, one after the other, on every
device. With two or more accelerators, `DeviceActor` runs the simulator and the policy
(the compiled K-step unroll) on one device while the learner updates on another: the
split loop (`host_actor.SplitLoop`) acts in a thread with the newest parameters the
learner has published, so the policy lags by up to `queue_size` updates, which the
V-trace loss corrects. Each trajectory is copied to the learner's device, and each
update's parameters to the actor's.

The actor's state (the environments) lives on its device and is not checkpointed: a
resumed run starts new episodes.
"""

from __future__ import annotations

from typing import Any

import jax

from sc2jax.checks import check_positive_int
from sc2jax.experiments.training.actor import Unroll
from sc2jax.losses.learner_loss import Trajectory


class DeviceActor:
    """The compiled actor of `num_envs` environments on `device`, for the split loop.

    Args:
      unroll: the compiled actor (`actor.make_unroll`).
      num_envs: environments stepped together.
      key: the actor's PRNG key (environments and actions).
      device: where the environments step and the policy acts.
      learner_device: where the trajectories go (default: `device`).

    Attributes:
      episode_returns: the return of every episode that has ended, in order.
    """

    def __init__(self, unroll: Unroll, num_envs: int, key: jax.Array, device: jax.Device,
                 learner_device: jax.Device | None = None):
        check_positive_int("num_envs", num_envs)
        self._device = device
        self._learner_device = device if learner_device is None else learner_device
        self._unroll = jax.jit(unroll.unroll, donate_argnums=1)
        init = jax.jit(lambda k: unroll.init(k, num_envs))
        self._state = init(jax.device_put(key, device))
        self.episode_returns: list[float] = []

    def unroll(self, params: Any) -> Trajectory:
        """K steps of every environment with `params`: the trajectory on the learner's
        device, leaves [K(+1), B, ...]."""
        params = jax.device_put(params, self._device)
        self._state, trajectory, episodes = self._unroll(params, self._state)
        ended, score = jax.device_get((episodes.ended, episodes.score))
        self.episode_returns.extend(score[ended].tolist())
        return jax.device_put(trajectory, self._learner_device)
