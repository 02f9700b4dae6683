"""Actors: a policy core of pure functions, and a compiled K-step unroll on the simulator.

`ActorCore` is what any actor needs from a network: an initial recurrent carry and a
jittable `act(params, key, carry, observation, first)` that samples an action and its
behaviour log-probability. The compiled actor (`make_unroll`) steps a batch of
simulator environments with it for K steps inside `lax.scan` and emits a `Trajectory`
for the learner; a host actor (`host_actor.py`) drives non-JAX environments with the
same core and emits the same `Trajectory`.

Episode boundaries follow dm_env: a step from a LAST observation starts a new episode
and returns its FIRST observation (reward 0, discount 0). The learner therefore sees
the LAST observation as an absorbing state whose value target is 0; the action taken
there is ignored by the game and, with a value close to 0, carries almost no gradient.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import dm_env
import flax.linen as nn
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from sc2jax.checks import check_positive_int
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface import narrow
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.functions import FUNCTIONS, RAW_FUNCTIONS
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.environment.interface.suggest import did_you_mean
from sc2jax.losses.learner_loss import Trajectory
from sc2jax.networks import policy
from sc2jax.networks.factory import act as feed_forward_act
from sc2jax.networks.fully_conv_lstm import FullyConvLSTM
from sc2jax.networks.raw_policy import policy_of


class ActorCore(NamedTuple):
    """A network's acting functions.

    Attributes:
      initial_carry: batch size -> the recurrent carry before any step (None for
        feed-forward networks).
      act: `(params, key, carry, observation, first) -> (carry, action, log_prob)` with
        observation leaves [B, ...], first bool[B] (True at an episode's first
        observation), the sampled `DenseAction` [B] (`RawAction` of a raw network) and
        its log-probability float32[B].
        The observation must have passed through `observe`.
      observe: environment observation -> the agent's observation (the action set
        restricted); actors store what it returns, so the learner sees the same masks.
    """

    initial_carry: Callable[[int], Any]
    act: Callable[..., tuple[Any, DenseAction, jax.Array]]
    observe: Callable[[dict], dict]


def function_mask(functions: Sequence[int | str] | None, raw: bool = False
                  ) -> np.ndarray | None:
    """bool[573] of the named function ids or names (None: every function); with `raw`,
    bool[564] of `RAW_FUNCTIONS`' names or ids.

    Raises:
      ValueError: for an unknown function, or a set without no_op (which is always
        available, so that the agent can always act).
    """
    if functions is None:
        return None
    table = RAW_FUNCTIONS if raw else FUNCTIONS
    mask = np.zeros(len(table), bool)
    for function in functions:
        if function not in table:
            hint = did_you_mean(function, [f.name for f in table])
            raise ValueError(f"unknown {'raw ' if raw else ''}function {function!r}; give "
                             f"PySC2 names or ids 0..{len(table) - 1}{hint}")
        mask[table[function].id] = True
    if not mask[0]:
        raise ValueError(f"the action set {list(functions)} must include no_op")
    return mask


def actor_core(network: nn.Module, temperature: float = 1.0,
               functions: Sequence[int | str] | None = None) -> ActorCore:
    """The acting functions of any of the networks.

    Args:
      network: an AtariNet, FullyConv, FullyConvLSTM, ARFullyConv or RawFullyConv.
      temperature: softmax temperature of the sampled actions (> 0).
      functions: restrict the agent to these function names or ids (None: all 573,
        the paper's setting; a raw network's of the 564 `RAW_FUNCTIONS`); they are
        still masked by availability.

    Raises:
      ValueError: for a non-positive temperature or a bad action set.
    """
    if not temperature > 0:
        raise ValueError(f"temperature must be > 0, got {temperature!r}")
    mask = function_mask(functions, network.spec.action_space == "raw")

    def observe(obs: dict) -> dict:
        if mask is None:
            return obs
        return dict(obs, available_actions_mask=obs["available_actions_mask"] & mask)

    if isinstance(network, FullyConvLSTM):
        def act_lstm(params, key, carry, obs, first):
            carry, out = network.apply(params, carry, obs, first, method="step")
            action = policy.sample(key, out, obs["available_actions_mask"], temperature)
            return carry, action, policy.log_prob(out, action, obs["available_actions_mask"]).total

        return ActorCore(network.initial_carry, act_lstm, observe)

    def act(params, key, carry, obs, first):
        del first
        action, out = feed_forward_act(network, params, key, obs, temperature)
        return carry, action, policy_of(out).log_prob(
            out, action, obs["available_actions_mask"]).total

    return ActorCore(lambda batch_size: None, act, observe)


class ActorState(struct.PyTreeNode):
    """The compiled actor's state for B environments.

    Attributes:
      env_state: the simulator states, leaves [B, ...].
      timestep: the last `dm_env.TimeStep` of each environment, leaves [B, ...].
      carry: the recurrent carry (None for feed-forward networks).
      episode_return: float32[B] the running return of each environment's episode.
      key: the actor's PRNG key.
    """

    env_state: Any
    timestep: dm_env.TimeStep
    carry: Any
    episode_return: jax.Array
    key: jax.Array


class EpisodeLog(NamedTuple):
    """Episodes that ended during an unroll.

    Attributes:
      ended: bool[T, B] an episode ended (LAST) at this step.
      score: float32[T, B] its return where `ended` (0 elsewhere).
    """

    ended: jax.Array
    score: jax.Array


def stored(observation: dict, fmt: ObservationFormat) -> dict:
    """An observation as a trajectory keeps it: its feature layers packed into bytes
    (`narrow.pack_observation`: 0.29 of int32's bytes with every layer, a quarter with
    narrow layers only), which the networks read as they are."""
    return narrow.pack_observation(observation, fmt.screen_layers, fmt.minimap_layers)


class Unroll(NamedTuple):
    """The compiled actor: `init(key, num_envs) -> ActorState` and
    `unroll(params, state) -> (state, Trajectory [T], EpisodeLog [T])`."""

    init: Callable[[jax.Array, int], ActorState]
    unroll: Callable[[Any, ActorState], tuple[ActorState, Trajectory, EpisodeLog]]


def make_unroll(sim: Simulator, core: ActorCore, unroll_length: int) -> Unroll:
    """Builds the compiled actor for a simulator (pure, jittable and vmappable).

    Args:
      sim: the simulator.
      core: the acting functions.
      unroll_length: K, the steps per trajectory (40 in the paper).

    Raises:
      ValueError: for a non-positive `unroll_length`.
    """
    check_positive_int("unroll_length", unroll_length)
    reset = jax.vmap(sim.reset)
    # Each observation is written into the last one (`Simulator.step`'s `previous`).
    step = jax.vmap(lambda env_state, action, obs: sim.step(env_state, action,
                                                            previous=obs))

    def init(key: jax.Array, num_envs: int) -> ActorState:
        env_key, key = jax.random.split(key)
        env_state, timestep = reset(jax.random.split(env_key, num_envs))
        return ActorState(env_state, timestep, core.initial_carry(num_envs),
                          jnp.zeros(num_envs, jnp.float32), key)

    def one_step(params, state: ActorState, _):
        key, act_key = jax.random.split(state.key)
        obs, first = core.observe(state.timestep.observation), state.timestep.first()
        carry, action, log_prob = core.act(params, act_key, state.carry, obs, first)
        env_state, ts = step(state.env_state, action, state.timestep.observation)
        episode_return = state.episode_return + ts.reward
        last = ts.last()
        record = dict(observation=stored(obs, sim.fmt), first=first, action=action,
                      reward=ts.reward, discount=ts.discount, log_prob=log_prob,
                      episode=EpisodeLog(last, jnp.where(last, episode_return, 0.0)))
        episode_return = jnp.where(last | ts.first(), 0.0, episode_return)
        return ActorState(env_state, ts, carry, episode_return, key), record

    def unroll(params, state: ActorState):
        initial_carry = state.carry
        state, rec = jax.lax.scan(lambda s, x: one_step(params, s, x), state, None,
                                  length=unroll_length)
        observation = jax.tree.map(lambda xs, x: jnp.concatenate([xs, x[None]]),
                                   rec["observation"],
                                   stored(core.observe(state.timestep.observation), sim.fmt))
        first = jnp.concatenate([rec["first"], state.timestep.first()[None]])
        trajectory = Trajectory(observation=observation, action=rec["action"],
                                reward=rec["reward"], discount=rec["discount"], first=first,
                                behaviour_log_prob=rec["log_prob"],
                                initial_carry=initial_carry)
        return state, trajectory, rec["episode"]

    return Unroll(init, unroll)
