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
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time

import jax

from sc2jax.environment.agents import random_action
from sc2jax.experiments.actor import make_unroll
from sc2jax.experiments.compiled_loop import make_train_step
from sc2jax.experiments.config import TrainConfig
from sc2jax.experiments.markdown import write_section
from sc2jax.experiments.trainer import build

SECTION = "## Training throughput on {platform}"


def _time(fn, *args, repeats: int) -> float:
    """Seconds per call after one compiling call (inputs are not donated)."""
    jax.block_until_ready(fn(*args))
    start = time.perf_counter()
    for _ in range(repeats):
        out = fn(*args)
    jax.block_until_ready(out)
    return (time.perf_counter() - start) / repeats


def measure(config: TrainConfig, repeats: int) -> dict:
    """Times one config's training step and its parts."""
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
                keys, ts.observation["available_actions"])
            return jax.vmap(sim.step)(env_state, action), None

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
    steps = k * config.num_envs
    return {"agent": config.agent, "size": config.screen_size,
            "steps_per_s": steps / times["step"],
            "env": times["env"] / times["step"],
            "acting": max(times["unroll"] - times["env"], 0.0) / times["step"],
            "learning": times["update"] / times["step"]}


def table(rows: list[dict], header: str) -> str:
    lines = [header, "",
             "| network | resolution | agent steps/s | environment | acting | learning |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['agent']} | {r['size']}² | {r['steps_per_s']:,.0f} | "
                     f"{r['env']:.0%} | {r['acting']:.0%} | {r['learning']:.0%} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--agents", default="atari,fullyconv,fullyconv_lstm,arfullyconv")
    parser.add_argument("--sizes", default="32,64")
    parser.add_argument("--num_envs", type=int, default=16)
    parser.add_argument("--unroll_length", type=int, default=40)
    parser.add_argument("--map", default="MoveToBeacon")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--write", action="store_true")
    args = parser.parse_args()
    rows = []
    for size in (int(s) for s in args.sizes.split(",")):
        for agent in args.agents.split(","):
            config = TrainConfig(map_name=args.map, agent=agent, screen_size=size,
                                 minimap_size=size, num_envs=args.num_envs,
                                 unroll_length=args.unroll_length)
            rows.append(measure(config, args.repeats))
            print(table(rows[-1:], "").strip().splitlines()[-1], flush=True)
    device = jax.devices()[0]
    command = " ".join(["python -m sc2jax.experiments.benchmark_training", *sys.argv[1:]])
    section = SECTION.format(platform=device.platform.upper())
    header = (f"{section}\n\n`{command}` "
              f"({args.map}, all feature layers, {args.num_envs} environments, K = "
              f"{args.unroll_length}, {device.platform} {device.device_kind}, "
              f"{os.cpu_count()} cores, {platform.machine()}, jax {jax.__version__}). "
              f"Shares are of the whole training step's time.")
    text = table(rows, header)
    print(text)
    if args.write:
        write_section(os.path.join(os.path.dirname(__file__), "..", "..", "docs",
                                   "benchmarks.md"), text)


if __name__ == "__main__":
    main()
