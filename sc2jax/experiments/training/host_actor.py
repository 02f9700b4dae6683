"""The split loop: actors step non-JAX environments outside the compiled program and
feed the same learner.

    learner_state, metrics = run_split_loop(actor, learner, learner_state, num_updates)

A `HostActor` drives any batched `dm_env.Environment` whose timesteps carry padded
observations with a leading batch dimension and which takes a batched `DenseAction`
(`BatchedSC2Env`, and the real game's `game_env.GameEnvBatch`). It acts with the jitted
`ActorCore.act`, collects K steps and emits the learner's `Trajectory` with the
behaviour log-probabilities. A `SplitLoop` (or `run_split_loop`) runs the actor in a
thread that always acts with the newest parameters the learner has published; the
learner consumes trajectories from a bounded queue, so the acting policy lags the
learned one by up to `queue_size` updates, which the V-trace loss corrects
(`off_policy_correction="vtrace"`).
"""

from __future__ import annotations

import queue
import threading
from typing import Any

import dm_env
import jax
import numpy as np

from sc2jax.checks import check_positive_int
from sc2jax.experiments.training.actor import ActorCore
from sc2jax.experiments.training.learner import Learner, LearnerState
from sc2jax.losses.learner_loss import Trajectory


class HostActor:
    """Acts in a batched dm_env environment and returns K-step trajectories.

    Args:
      env: a batched `dm_env.Environment` of B environments (see the module docstring).
      core: the acting functions.
      unroll_length: K.
      seed: the actor's PRNG seed.
    """

    def __init__(self, env: dm_env.Environment, core: ActorCore, unroll_length: int,
                 seed: int = 0):
        check_positive_int("unroll_length", unroll_length)
        self._env, self._core, self._k = env, core, unroll_length
        self._act = jax.jit(core.act)
        self._observe = jax.jit(core.observe)
        self._key = jax.random.PRNGKey(seed)
        self._timestep = env.reset()
        self._batch = int(np.shape(self._timestep.step_type)[0])
        self._carry = core.initial_carry(self._batch)
        self.episode_returns: list[float] = []
        self._returns = np.zeros(self._batch, np.float64)

    def unroll(self, params: Any) -> Trajectory:
        """K steps of every environment with `params`; leaves [K(+1), B, ...]."""
        initial_carry = self._carry
        observations, firsts, actions, rewards, discounts, log_probs = [], [], [], [], [], []
        for _ in range(self._k):
            obs = jax.device_get(self._observe(self._timestep.observation))
            first = np.asarray(self._timestep.step_type) == dm_env.StepType.FIRST
            self._key, key = jax.random.split(self._key)
            self._carry, action, log_prob = self._act(params, key, self._carry, obs, first)
            action = jax.device_get(action)
            self._timestep = self._env.step(action)
            observations.append(obs)
            firsts.append(first)
            actions.append(action)
            rewards.append(np.asarray(self._timestep.reward, np.float32))
            discounts.append(np.asarray(self._timestep.discount, np.float32))
            log_probs.append(np.asarray(log_prob))
            self._record(rewards[-1])
        observations.append(jax.device_get(self._observe(self._timestep.observation)))
        firsts.append(np.asarray(self._timestep.step_type) == dm_env.StepType.FIRST)

        def stack(xs):
            return jax.tree.map(lambda *x: np.stack(x), *xs)

        return Trajectory(observation=stack(observations), action=stack(actions),
                          reward=np.stack(rewards), discount=np.stack(discounts),
                          first=np.stack(firsts), behaviour_log_prob=np.stack(log_probs),
                          initial_carry=initial_carry)

    def _record(self, reward: np.ndarray) -> None:
        step_type = np.asarray(self._timestep.step_type)
        self._returns += reward
        for i in np.flatnonzero(step_type == dm_env.StepType.LAST):
            self.episode_returns.append(float(self._returns[i]))
        self._returns[step_type != dm_env.StepType.MID] = 0.0


class SplitLoop:
    """An actor thread that acts with the newest parameters the learner has published
    and feeds it trajectories through a bounded queue; `run` applies updates from them.
    The thread keeps acting between calls to `run` (e.g. while the caller logs or
    checkpoints), so no trajectory is thrown away until `close`.

    Args:
      actor: the host actor (its environment is only touched by the actor thread).
      learner: the learner (use the V-trace loss for lagging actors).
      params: the parameters to act with until the first update.
      queue_size: trajectories that may wait for the learner (the policy lag).
    """

    def __init__(self, actor: HostActor, learner: Learner, params: Any, *,
                 queue_size: int = 2):
        check_positive_int("queue_size", queue_size)
        self._trajectories: queue.Queue = queue.Queue(maxsize=queue_size)
        self._latest = {"params": params}
        self._stop = threading.Event()
        self._errors: list[BaseException] = []
        self._update = jax.jit(learner.update)
        self._thread = threading.Thread(target=self._act, args=(actor,),
                                        name="sc2jax-host-actor", daemon=True)
        self._thread.start()

    def _act(self, actor: HostActor) -> None:
        try:
            while not self._stop.is_set():
                trajectory = actor.unroll(self._latest["params"])
                while not self._stop.is_set():
                    try:
                        self._trajectories.put(trajectory, timeout=0.1)
                        break
                    except queue.Full:
                        continue
        except BaseException as error:  # re-raised in the learner's thread
            self._errors.append(error)
            self._stop.set()

    def run(self, state: LearnerState, num_updates: int) -> tuple[LearnerState, list]:
        """Applies `num_updates` updates; returns the new state and each update's metrics.

        Raises:
          Whatever the actor thread raised.
        """
        check_positive_int("num_updates", num_updates)
        metrics = []
        while len(metrics) < num_updates:
            if self._errors:
                raise self._errors[0]
            try:
                trajectory = self._trajectories.get(timeout=0.1)
            except queue.Empty:
                continue
            state, m = self._update(state, trajectory)
            self._latest["params"] = state.params
            metrics.append(jax.device_get(m))
        return state, metrics

    def close(self) -> None:
        """Stops the actor thread (after its current unroll)."""
        self._stop.set()
        self._thread.join()

    def __enter__(self) -> SplitLoop:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def run_split_loop(actor: HostActor, learner: Learner, state: LearnerState,
                   num_updates: int, *, queue_size: int = 2) -> tuple[LearnerState, list]:
    """Trains for `num_updates` updates with a `SplitLoop`.

    Returns:
      (the final learner state, the metrics of every update).

    Raises:
      Whatever the actor thread raised.
    """
    check_positive_int("num_updates", num_updates)
    with SplitLoop(actor, learner, state.params, queue_size=queue_size) as loop:
        return loop.run(state, num_updates)
