"""Evaluating a policy on the simulator: many episodes in one compiled program.

A policy is a pure function `(key, observation) -> DenseAction` of one environment's
padded observation; it is vmapped over `num_envs` environments that run one episode
each inside a `lax.scan`, so a batch of episodes is a single jitted call.

`run_host_episodes` evaluates on environments outside JAX (the real game's
`game_env.GameEnvBatch`), stepping them from the host.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import dm_env
import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.checks import check_positive_int
from sc2jax.environment.agents import random_action, scripted_policy
from sc2jax.environment.agents.calls import Policy
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.episodes import Episode
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.experiments.training.actor import ActorCore

AGENTS = ("random", "scripted")


def make_policy(agent: str, map_name: str, fmt: ObservationFormat) -> Policy:
    """A policy without parameters by name: "random" (the paper's random policy) or
    "scripted" (the map's scripted agent), for observations of `fmt`.

    Raises:
      ValueError: for an unknown agent, or a map or format the agent cannot play.
    """
    if agent == "random":
        types = fmt.types
        return lambda key, obs: random_action(key, obs["available_actions_mask"], types)
    if agent == "scripted":
        return scripted_policy(map_name, fmt)
    raise ValueError(f"unknown agent {agent!r}; allowed: {list(AGENTS)}")


def max_episode_steps(sim: Simulator) -> int:
    """Agent steps in the longest possible episode (the map's timer)."""
    return -(-sim.game.time_limit_loops // sim.step_mul)


@dataclasses.dataclass(frozen=True)
class EpisodeStats:
    """Scores of finished episodes.

    Attributes:
      scores: float64[E] each episode's return (the sum of its rewards).
      steps: int64[E] each episode's length in agent steps.
    """

    scores: np.ndarray
    steps: np.ndarray

    @property
    def summary(self) -> dict:
        s = self.scores
        return {"episodes": int(s.size), "mean": float(s.mean()), "std": float(s.std()),
                "max": float(s.max()), "min": float(s.min())}


@functools.cache
def _episode_batch(sim: Simulator, policy: Policy, num_envs: int):
    """A jitted function key -> (returns float32[num_envs], lengths int32[num_envs])."""
    length = max_episode_steps(sim)

    def one_env(key):
        reset_key, run_key = jax.random.split(key)
        state, ts = sim.reset(reset_key)

        def body(carry, key):
            state, ts, done, score, steps = carry
            state, ts = sim.step(state, policy(key, ts.observation), previous=ts.observation)
            score = score + jnp.where(done, 0.0, ts.reward)
            steps = steps + jnp.where(done, 0, 1)
            done = done | ts.last()
            return (state, ts, done, score, steps), None

        init = (state, ts, jnp.bool_(False), jnp.float32(0.0), jnp.int32(0))
        (_, _, done, score, steps), _ = jax.lax.scan(
            body, init, jax.random.split(run_key, length))
        return score, steps, done

    return jax.jit(jax.vmap(one_env))


def core_episodes_fn(sim: Simulator, core, num_envs: int, record: bool = False):
    """A pure function (params, key) -> (returns float32[num_envs], lengths
    int32[num_envs], done bool[num_envs]): one episode in each of `num_envs`
    environments, acting with an `ActorCore` (vmap it over parameters to evaluate many
    policies at once).

    With `record`, it also returns each environment's reset key (uint32[num_envs, 2]),
    and the actions (a `DenseAction` [T, num_envs]) and rewards (float32[T, num_envs])
    of every step (those after an episode's end included), for `record_episodes`.
    """
    length = max_episode_steps(sim)
    reset = jax.vmap(sim.reset)
    step = jax.vmap(lambda state, action, obs: sim.step(state, action, previous=obs))

    def run(params, key):
        reset_key, run_key = jax.random.split(key)
        reset_keys = jax.random.split(reset_key, num_envs)
        state, ts = reset(reset_keys)

        def body(carry, key):
            state, ts, core_carry, done, score, steps = carry
            core_carry, action, _ = core.act(params, key, core_carry,
                                             core.observe(ts.observation), ts.first())
            state, ts = step(state, action, ts.observation)
            score = score + jnp.where(done, 0.0, ts.reward)
            steps = steps + jnp.where(done, 0, 1)
            carry = (state, ts, core_carry, done | ts.last(), score, steps)
            return carry, (action, ts.reward) if record else None

        init = (state, ts, core.initial_carry(num_envs), jnp.zeros(num_envs, bool),
                jnp.zeros(num_envs, jnp.float32), jnp.zeros(num_envs, jnp.int32))
        (_, _, _, done, score, steps), trace = jax.lax.scan(
            body, init, jax.random.split(run_key, length))
        if record:
            return score, steps, done, reset_keys, trace[0], trace[1]
        return score, steps, done

    return run


def policy_core(policy: Policy) -> ActorCore:
    """A `Policy` as a feed-forward `ActorCore` (no parameters, no carry)."""

    def act(params, key, carry, obs, first):
        del params, first
        keys = jax.random.split(key, jnp.shape(obs["available_actions_mask"])[0])
        action = jax.vmap(policy)(keys, obs)
        return carry, action, jnp.zeros(keys.shape[0], jnp.float32)

    return ActorCore(initial_carry=lambda num_envs: None, act=act, observe=lambda obs: obs)


def record_episodes(sim: Simulator, core, params, episodes: int, seed: int = 0,
                    agent: str = "") -> list[Episode]:
    """Plays `episodes` episodes (one batch) and returns them as `Episode`s to save and
    replay (`sc2jax.environment.episodes`): the same episodes as the first batch of
    `run_core_episodes` with the same seed and `num_envs=episodes`.

    Args:
      sim: the simulator.
      core: an `ActorCore` (`policy_core` for a random or scripted policy).
      params: the core's parameters (None for a policy).
      episodes: how many (>= 1), played side by side.
      seed: RNG seed.
      agent: who played, stored in each episode.
    """
    check_positive_int("episodes", episodes)
    run = jax.jit(core_episodes_fn(sim, core, episodes, record=True))
    _, batch_key = jax.random.split(jax.random.PRNGKey(seed))  # As `_collect`'s first.
    _, steps, done, keys, actions, rewards = jax.device_get(run(params, batch_key))
    out = []
    for i in range(episodes):
        if not done[i]:
            raise RuntimeError(f"episode {i} did not end within {max_episode_steps(sim)} "
                               f"steps")
        n = int(steps[i])
        out.append(Episode(
            map_name=sim.map_name, screen_size=sim.fmt.screen_size,
            minimap_size=sim.fmt.minimap_size, step_mul=sim.step_mul,
            key=np.asarray(keys[i], np.uint32),
            actions=DenseAction(*(np.asarray(a[:n, i]) for a in actions)),
            rewards=np.asarray(rewards[:n, i], np.float32), score_index=sim.score_index,
            score_multiplier=sim.score_multiplier, agent=agent))
    return out


@functools.cache
def _core_episode_batch(sim: Simulator, core, num_envs: int):
    return jax.jit(core_episodes_fn(sim, core, num_envs))


def _check_counts(episodes: int, num_envs: int) -> None:
    check_positive_int("episodes", episodes)
    check_positive_int("num_envs", num_envs)


def _collect(sim: Simulator, batch: Callable, episodes: int, num_envs: int, seed: int,
             on_batch: Callable[[EpisodeStats], None] | None) -> EpisodeStats:
    """Calls `batch(key) -> (score, length, done)` until `episodes` episodes are done."""
    key = jax.random.PRNGKey(seed)
    scores, steps = [], []
    while sum(map(len, scores)) < episodes:
        key, batch_key = jax.random.split(key)
        score, length, done = jax.device_get(batch(batch_key))
        if not done.all():
            raise RuntimeError(f"{int((~done).sum())} episodes did not end within "
                               f"{max_episode_steps(sim)} steps")
        scores.append(score.astype(np.float64))
        steps.append(length.astype(np.int64))
        if on_batch is not None:
            on_batch(EpisodeStats(np.concatenate(scores)[:episodes],
                                  np.concatenate(steps)[:episodes]))
    return EpisodeStats(np.concatenate(scores)[:episodes], np.concatenate(steps)[:episodes])


def run_episodes(sim: Simulator, policy: Policy, episodes: int, num_envs: int = 64,
                 seed: int = 0, on_batch: Callable[[EpisodeStats], None] | None = None
                 ) -> EpisodeStats:
    """Runs `episodes` full episodes of `policy`, `num_envs` at a time.

    Args:
      sim: the simulator.
      policy: (key, padded observation) -> unbatched DenseAction.
      episodes: how many episodes (>= 1).
      num_envs: environments per compiled batch (>= 1).
      seed: RNG seed; the same seed gives the same episodes.
      on_batch: called with the stats so far after each batch (progress reporting).

    Returns:
      The episodes' stats, in order.

    Raises:
      ValueError: for non-positive `episodes` or `num_envs`.
    """
    _check_counts(episodes, num_envs)
    num_envs = min(num_envs, episodes)
    batch = _episode_batch(sim, policy, num_envs)
    return _collect(sim, lambda key: batch(jax.random.split(key, num_envs)), episodes,
                    num_envs, seed, on_batch)


def run_core_episodes(sim: Simulator, core, params, episodes: int, num_envs: int = 64,
                      seed: int = 0, on_batch: Callable[[EpisodeStats], None] | None = None
                      ) -> EpisodeStats:
    """Runs `episodes` full episodes of a network's `ActorCore` (any of the four networks,
    recurrent ones included), `num_envs` at a time; arguments as `run_episodes`."""
    _check_counts(episodes, num_envs)
    num_envs = min(num_envs, episodes)
    batch = _core_episode_batch(sim, core, num_envs)
    return _collect(sim, lambda key: batch(params, key), episodes, num_envs, seed, on_batch)


HostAct = Callable[[jax.Array, Any, dict, np.ndarray], tuple[Any, DenseAction]]


def host_policy(policy: Policy) -> HostAct:
    """A `Policy` as a `HostAct` for `run_host_episodes` (batched, jitted, no carry)."""
    return host_core(policy_core(policy), None)


def host_core(core, params) -> HostAct:
    """A network's `ActorCore` with its parameters as a `HostAct`."""
    act = jax.jit(lambda params, key, carry, obs, first: core.act(
        params, key, carry, core.observe(obs), first)[:2])
    return lambda key, carry, obs, first: act(params, key, carry, obs, first)


def run_host_episodes(env: dm_env.Environment, act: HostAct, carry: Any, episodes: int,
                      seed: int = 0,
                      on_batch: Callable[[EpisodeStats], None] | None = None
                      ) -> EpisodeStats:
    """Runs `episodes` full episodes in a batched environment stepped on the host.

    Each of the B environments plays ceil(episodes / B) episodes from a reset, and the
    stats take every environment's first episode, then every second one, and so on, so
    short episodes are not favoured over long ones.

    Args:
      env: a batched dm_env environment with auto-reset (`game_env.GameEnvBatch`):
        padded observations [B, ...], a batched `DenseAction` in.
      act: `(key, carry, observation [B, ...], first bool[B]) -> (carry, action [B])`
        (`host_policy`, `host_core`).
      carry: the acting carry for B environments (None for feed-forward acting).
      episodes: how many episodes (>= 1).
      seed: the acting RNG seed.
      on_batch: called with the stats so far each time every environment has finished
        one more episode.

    Returns:
      The episodes' stats.
    """
    check_positive_int("episodes", episodes)
    timestep = env.reset()
    num_envs = int(np.shape(timestep.step_type)[0])
    per_env = -(-episodes // num_envs)
    scores = [[] for _ in range(num_envs)]
    lengths = [[] for _ in range(num_envs)]
    score, length = np.zeros(num_envs), np.zeros(num_envs, np.int64)
    key = jax.random.PRNGKey(seed)
    rounds = 0

    def stats() -> EpisodeStats:
        done = min(map(len, scores))
        order = [(i, k) for k in range(done) for i in range(num_envs)][:episodes]
        return EpisodeStats(np.array([scores[i][k] for i, k in order], np.float64),
                            np.array([lengths[i][k] for i, k in order], np.int64))

    while min(map(len, scores)) < per_env:
        first = np.asarray(timestep.step_type) == dm_env.StepType.FIRST
        key, act_key = jax.random.split(key)
        carry, action = act(act_key, carry, timestep.observation, first)
        timestep = env.step(jax.device_get(action))
        step_type = np.asarray(timestep.step_type)
        score += np.asarray(timestep.reward, np.float64)
        length += 1
        for i in np.flatnonzero(step_type == dm_env.StepType.LAST):
            scores[i].append(float(score[i]))
            lengths[i].append(int(length[i]))
        score[step_type != dm_env.StepType.MID] = 0.0
        length[step_type != dm_env.StepType.MID] = 0
        if on_batch is not None and min(map(len, scores)) > rounds:
            rounds = min(map(len, scores))
            on_batch(stats())
    return stats()
