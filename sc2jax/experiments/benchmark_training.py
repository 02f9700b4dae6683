r"""End-to-end training throughput: agent steps per second with learning included.

    python -m sc2jax.experiments.benchmark_training --write

For each network and resolution it times, on the same batch of environments, the
compiled training step (`compiled_loop.make_train_step`: K environment steps with
acting, then one update) and its parts: the K environment steps alone (random
actions), the actor's unroll (environments and acting) and the learner's update.
The shares are environment = env / step, acting = (unroll - env) / step and learning
= update / step (they need not sum to 1: XLA fuses the parts differently in the
whole step). With --write the table replaces the "Training throughput on CPU" (or
"on GPU") section of docs/benchmarks.md.

With --pipelined it also times training's pipelined chunk (`train --pipelined`: each
program acts for the next batch and learns from the last, which do not depend on each
other; the actor a policy one update behind, as in IMPALA) against the plain chunk, both
of `PIPELINED_UPDATES` updates: "pipelined" is the plain chunk's time over the pipelined
one's. Near 1 the hardware runs acting and learning one after the other; at most
1 / max(acting + environment, learning) if it runs them at once.
"""

from __future__ import annotations

import os
import platform
import sys
import time

import jax
import jax.numpy as jnp
from absl import app, flags

from sc2jax.checks import check_positive_int, positive_ints
from sc2jax.environment.agents import random_action
from sc2jax.experiments.reporting.markdown import write_section
from sc2jax.experiments.training.actor import make_unroll
from sc2jax.experiments.training.compiled_loop import make_train_chunk, make_train_step
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.trainer import build

SECTION = "## Training throughput on {platform}"
PIPELINED_UPDATES = 4
"""Updates per chunk in the --pipelined comparison (its first acts and last learns alone)."""


def _time(fn, *args, repeats: int) -> float:
    """Seconds per call after one compiling call (inputs are not donated)."""
    jax.block_until_ready(fn(*args))
    start = time.perf_counter()
    for _ in range(repeats):
        out = fn(*args)
    jax.block_until_ready(out)
    return (time.perf_counter() - start) / repeats


def _time_chunk(chunk, state, repeats: int) -> float:
    """Seconds per call of a training chunk after one compiling call (the chunk donates
    its input, so each call takes the state the last one returned)."""
    state = jax.block_until_ready(chunk(jax.tree.map(jnp.copy, state))[0])
    start = time.perf_counter()
    for _ in range(repeats):
        state = chunk(state)[0]
    jax.block_until_ready(state)
    return (time.perf_counter() - start) / repeats


def measure(config: TrainConfig, repeats: int, pipelined: bool = False) -> dict:
    """Times one config's training step and its parts (and the pipelined program)."""
    agent = build(config)
    sim, k = agent.sim, config.unroll_length
    state = agent.initial_state(jax.random.PRNGKey(0))
    unroll = make_unroll(sim, agent.core, k)
    types = sim.fmt.types

    def env_only(actor):
        def body(carry, key):
            env_state, ts = carry
            keys = jax.random.split(key, config.num_envs)
            action = jax.vmap(lambda kk, a: random_action(kk, a, types))(
                keys, ts.observation["available_actions_mask"])
            step = lambda s, a, o: sim.step(s, a, previous=o)  # noqa: E731
            return jax.vmap(step)(env_state, action, ts.observation), None

        return jax.lax.scan(body, (actor.env_state, actor.timestep),
                            jax.random.split(actor.key, k))[0][1].reward

    _, trajectory, _ = jax.jit(unroll.unroll)(state.learner.params, state.actor)
    step = jax.jit(make_train_step(unroll, agent.learner))
    times = {
        "env": _time(jax.jit(env_only), state.actor, repeats=repeats),
        "unroll": _time(jax.jit(unroll.unroll), state.learner.params, state.actor,
                        repeats=repeats),
        "update": _time(jax.jit(agent.learner.update), state.learner, trajectory,
                        repeats=repeats),
        "step": _time(step, state, repeats=repeats),
    }
    if pipelined:
        chunks = {p: make_train_chunk(unroll, agent.learner, PIPELINED_UPDATES, pipelined=p)
                  for p in (False, True)}
        plain, overlapped = (_time_chunk(chunks[p], state, repeats) for p in (False, True))
    steps = k * config.num_envs
    return {"agent": config.agent, "size": config.screen_size,
            "steps_per_s": steps / times["step"],
            "env": times["env"] / times["step"],
            "acting": max(times["unroll"] - times["env"], 0.0) / times["step"],
            "learning": times["update"] / times["step"],
            **({"pipelined": plain / overlapped} if pipelined else {})}


def table(rows: list[dict], header: str) -> str:
    extra = "pipelined" in rows[0]
    lines = [header, "",
             "| network | resolution | agent steps/s | environment | acting | learning |"
             + (" pipelined |" if extra else ""), "|---|---|---|---|---|---|"
             + ("---|" if extra else "")]
    for r in rows:
        lines.append(f"| {r['agent']} | {r['size']}² | {r['steps_per_s']:,.0f} | "
                     f"{r['env']:.0%} | {r['acting']:.0%} | {r['learning']:.0%} |"
                     + (f" {r['pipelined']:.2f} |" if extra else ""))
    return "\n".join(lines)


_NETWORKS = flags.DEFINE_list("networks",
                             ["atari", "fullyconv", "fullyconv_lstm", "arfullyconv"],
                             "Networks to measure.")
flags.DEFINE_alias("agents", "networks")  # The old name.
_SIZES = flags.DEFINE_list("sizes", ["32", "64"], "Screen and minimap sizes.")
_NUM_ENVS = flags.DEFINE_integer("num_envs", 16, "Environments stepped together.")
_UNROLL = flags.DEFINE_integer("unroll_length", 40, "K, agent steps per update.")
_MAP = flags.DEFINE_string("map", "MoveToBeacon", "Mini-game.")
_REPEATS = flags.DEFINE_integer("repeats", 3, "Timed calls per part (after a compiling one).")
_PIPELINED = flags.DEFINE_bool("pipelined", False,
                                "Also time acting and learning in one pipelined program.")
_WRITE = flags.DEFINE_bool("write", False, "Replace the section of docs/benchmarks.md.")


def main(argv) -> None:
    del argv
    sizes = positive_ints("sizes", _SIZES.value)
    check_positive_int("repeats", _REPEATS.value)
    configs = [TrainConfig(map_name=_MAP.value, agent=agent, screen_size=size,
                           minimap_size=size, num_envs=_NUM_ENVS.value,
                           unroll_length=_UNROLL.value)
               for size in sizes for agent in _NETWORKS.value]  # checks every flag first
    rows = []
    for config in configs:
        rows.append(measure(config, _REPEATS.value, _PIPELINED.value))
        print(table(rows[-1:], "").strip().splitlines()[-1], flush=True)
    device = jax.devices()[0]
    command = " ".join(["python -m sc2jax.experiments.benchmark_training", *sys.argv[1:]])
    section = SECTION.format(platform=device.platform.upper())
    header = (f"{section}\n\n`{command}` "
              f"({_MAP.value}, all feature layers, {_NUM_ENVS.value} environments, K = "
              f"{_UNROLL.value}, {device.platform} {device.device_kind}, "
              f"{os.cpu_count()} cores, {platform.machine()}, jax {jax.__version__}). "
              f"Shares are of the whole training step's time.")
    text = table(rows, header)
    print(text)
    if _WRITE.value:
        write_section(os.path.join(os.path.dirname(__file__), "..", "..", "docs",
                                   "benchmarks.md"), text)


if __name__ == "__main__":
    app.run(main)
