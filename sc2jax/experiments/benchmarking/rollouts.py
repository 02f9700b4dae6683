"""Timed random-policy rollouts of the simulator (and of JaxMARL's SMAX-3m as a reference),
and their markdown table: the library of `python -m sc2jax.experiments.benchmark`, whose
docstring describes the method.
"""

from __future__ import annotations

import datetime
import statistics
import time
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
from absl import logging

from sc2jax.environment.agents.random_agent import random_action
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.engine.xla.devices import over_devices
from sc2jax.environment.interface.specs import ObservationFormat

SECTION = "## Simulator throughput"
SMAX_SCENARIO = "3m"
THREAD_VARIABLES = ("PJRT_NPROC", "NPROC")
"""The environment variables XLA:CPU sizes its thread pool by, the first set winning."""


class Result(NamedTuple):
    """One measurement.

    Attributes:
      name: what was measured (a map name, or "SMAX-3m").
      num_envs: environments stepped together.
      devices: the devices they were split over.
      steps: agent steps per environment per timed call.
      seconds: the median wall time of one call.
      step_mul: game loops per agent step.
      reference: the SMAX-3m result timed in the same rounds (None if none was).
      threads: the XLA:CPU thread-pool size it ran with (0: XLA's default).
    """

    name: str
    num_envs: int
    devices: int
    steps: int
    seconds: float
    step_mul: int
    reference: Result | None = None
    threads: int = 0

    def to_json(self) -> dict:
        out = self._asdict()
        out["reference"] = None if self.reference is None else self.reference.to_json()
        return out

    @classmethod
    def from_json(cls, data: dict) -> Result:
        reference = data.get("reference")
        return cls(**{**data, "reference": None if reference is None
                      else cls.from_json(reference)})

    @property
    def agent_steps_per_second(self) -> float:
        return self.num_envs * self.steps / self.seconds

    @property
    def game_steps_per_second(self) -> float:
        return self.agent_steps_per_second * self.step_mul


def steps_per_call(num_envs: int, steps: int = 0) -> int:
    """K, the agent steps of one timed call: `steps`, or ~8192 agent steps in all."""
    return steps if steps > 0 else max(16, min(2048, 8192 // num_envs))


class Program(NamedTuple):
    """A compiled rollout to time: `rollout(carry) -> carry` runs `steps` agent steps of
    `num_envs` environments split over `devices` devices."""

    name: str
    num_envs: int
    devices: int
    steps: int
    step_mul: int
    rollout: Callable
    carry: Any


def time_round_robin(programs: Sequence[Program], repeats: int) -> list[Result]:
    """Times each program's median call, the programs taking turns.

    Every program is called twice untimed: the first call compiles for the initial carry,
    the second for the carry a call returns, which can differ from it in weak types
    (SMAX's does, and a timed call would otherwise include a compilation). Then
    `repeats` rounds time one call of each in turn. Each call continues from the
    previous call's carry, so episodes run on (and reset) as in training. The programs'
    initial carries are consumed (donated).
    """
    carries = []
    for p in programs:
        start = time.perf_counter()
        carries.append(jax.block_until_ready(p.rollout(p.rollout(p.carry))))
        logging.info("%s x%d on %d devices: compiled and warmed up in %.1f s", p.name,
                     p.num_envs, p.devices, time.perf_counter() - start)
    times: list[list[float]] = [[] for _ in programs]
    for _ in range(repeats):
        for i, p in enumerate(programs):
            start = time.perf_counter()
            carries[i] = jax.block_until_ready(p.rollout(carries[i]))
            times[i].append(time.perf_counter() - start)
    return [Result(p.name, p.num_envs, p.devices, p.steps, statistics.median(t), p.step_mul)
            for p, t in zip(programs, times)]


def per_env(fn: Callable, num_envs: int, in_axes=0, out_axes=0) -> Callable:
    """`jax.vmap(fn, in_axes, out_axes)` for `num_envs` environments; for one, `fn` run on
    it unbatched (its environment axis taken off the arguments and put back on the
    results), as a single environment (`environment.make(num_envs=None)`) runs.

    Under a `vmap`, even of one environment, a `switch` computes every branch and selects
    (`Simulator.step` applies an action by a switch over its kinds), and `lazy_where`
    keeps a batch's bookkeeping; unbatched, only the branch taken runs. The same bits;
    FindAndDefeatZerglings 1.080x at one environment (docs/benchmarks.md).
    """
    if num_envs != 1:
        return jax.vmap(fn, in_axes=in_axes, out_axes=out_axes)

    def one(*args):
        ins = in_axes if isinstance(in_axes, tuple) else (in_axes,) * len(args)
        args = [arg if axis is None else
                jax.tree_util.tree_map(lambda x, a=axis: jnp.squeeze(x, a), arg)
                for arg, axis in zip(args, ins)]
        return jax.tree_util.tree_map(lambda x: jnp.expand_dims(x, out_axes), fn(*args))

    return one


def split_keys(keys, num: int):
    """`num` keys [num, B, 2] from each of B keys [B, 2] (one split per environment)."""
    return per_env(lambda key: threefry.split(key, num), len(keys), out_axes=1)(keys)


def compiled_rollout(one_step: Callable, steps: int, devices: Sequence[jax.Device] | None):
    """jit(`lax.scan` of `steps` calls of `one_step`), the carry's environments split over
    `devices` (every leaf of the carry has the environment axis first; None: the default
    device alone). The carry is donated: a call consumes its argument, so one rollout
    holds one carry (at 16,384 environments of 64² layers, about 10 GB)."""
    def rollout(carry):
        return jax.lax.scan(one_step, carry, None, length=steps)[0]

    return jax.jit(over_devices(rollout, devices or jax.devices()[:1]), donate_argnums=0)


def sc2jax_rollout(sim: Simulator, num_envs: int, steps: int,
                   devices: Sequence[jax.Device] | None = None):
    """Builds a compiled random-policy rollout of `num_envs` environments.

    Args:
      devices: the devices to split the environments over (None: the default device).

    Returns:
      (rollout, carry): `rollout(carry) -> carry` runs `steps` agent steps; the carry is
      (states [B, ...], the last timesteps [B, ...] with their full observations, the
      random agent's keys [B, 2]).
    """
    types = sim.fmt.types
    act = per_env(random_action, num_envs, in_axes=(0, 0, None))
    # The new observation is written into the last one (`Simulator.step`'s `previous`).
    step = per_env(lambda state, action, obs: sim.step(state, action, previous=obs), num_envs)

    def one_step(carry, _):
        state, timestep, keys = carry
        keys, action_keys = split_keys(keys, 2)
        action = act(action_keys, timestep.observation["available_actions_mask"], types)
        state, timestep = step(state, action, timestep.observation)
        return (state, timestep, keys), None

    key, reset_key = jax.random.split(jax.random.PRNGKey(0))
    state, timestep = jax.jit(jax.vmap(sim.reset))(jax.random.split(reset_key, num_envs))
    return (compiled_rollout(one_step, steps, devices),
            (state, timestep, jax.random.split(key, num_envs)))


def sc2jax_program(map_name: str, num_envs: int, fmt: ObservationFormat, step_mul: int,
                   steps: int, devices: Sequence[jax.Device]) -> Program:
    """One mini-game's rollout at one environment count, split over `devices`."""
    sim = Simulator(map_name=map_name, fmt=fmt, step_mul=step_mul)
    return Program(map_name, num_envs, len(devices), steps, step_mul,
                   *sc2jax_rollout(sim, num_envs, steps, devices))


def smax_rollout(num_envs: int, steps: int, step_mul: int,
                 devices: Sequence[jax.Device] | None = None):
    """Builds SMAX-3m's compiled random-policy rollout, as `sc2jax_rollout`.

    Raises:
      ImportError: jaxmarl is not installed.
    """
    from jaxmarl.environments.smax import HeuristicEnemySMAX, map_name_to_scenario

    env = HeuristicEnemySMAX(scenario=map_name_to_scenario(SMAX_SCENARIO),
                             world_steps_per_env_step=step_mul)
    agents = env.agents

    def act_one(key, state):
        available = env.get_avail_actions(state)
        keys = jax.random.split(key, len(agents))
        return {a: jax.random.categorical(k, jnp.where(available[a], 0.0, -jnp.inf))
                for k, a in zip(keys, agents)}

    step = per_env(env.step, num_envs)

    def one_step(carry, _):
        state, obs, keys = carry
        keys, action_keys, step_keys = split_keys(keys, 3)
        actions = per_env(act_one, num_envs)(action_keys, state)
        obs, state, _, _, _ = step(step_keys, state, actions)
        return (state, obs, keys), None

    key, reset_key = jax.random.split(jax.random.PRNGKey(0))
    obs, state = jax.jit(jax.vmap(env.reset))(jax.random.split(reset_key, num_envs))
    return (compiled_rollout(one_step, steps, devices),
            (state, obs, jax.random.split(key, num_envs)))


def smax_program(num_envs: int, step_mul: int, steps: int,
                 devices: Sequence[jax.Device]) -> Program:
    """SMAX-3m's rollout at one environment count (ImportError without jaxmarl)."""
    return Program(f"SMAX-{SMAX_SCENARIO}", num_envs, len(devices), steps, step_mul,
                   *smax_rollout(num_envs, steps, step_mul, devices))


def markdown(results: Sequence[Result], smax: Sequence[Result], command: str, before: str,
             after: str, note: str) -> str:
    """The results section, as markdown. Each ratio is against the result's `reference`."""
    lines = [SECTION, "", f"Command: `{command}`", "",
             f"- Date: {datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}",
             f"- Machine before the run: {before}",
             f"- Load after the run: {after}", ""]
    header = "| Map | Envs | Devices | Threads | K | Agent steps/s | Game steps/s |"
    rule = "|---|---:|---:|---:|---:|---:|---:|"
    if smax:
        header += " × SMAX-3m |"
        rule += "---:|"
    lines += [header, rule]
    for r, base in [(r, r.reference) for r in results] + [(r, r) for r in smax]:
        row = (f"| {r.name} | {r.num_envs} | {r.devices} | {r.threads or 'XLA default'} | "
               f"{r.steps} | "
               f"{r.agent_steps_per_second:,.0f} | {r.game_steps_per_second:,.0f} |")
        if smax:
            row += (f" {r.agent_steps_per_second / base.agent_steps_per_second:.2f} |"
                    if base else " – |")
        lines.append(row)
    if note:
        lines += ["", note]
    return "\n".join(lines) + "\n"
