r"""The economy maps on their leading slots against all slots, A/B in one process.

BuildMarines and CollectMineralsAndGas run an agent step's game loops, and render its
observation, on the leading unit slots in use (`MiniGame.slot_sizes`); this times that
engine against the same engine on every slot (`Simulator(use_slot_sizes=False)`),
round-robin in one process: `--steps` agent steps of `--num_envs` environments in one
compiled `lax.scan`, the random agent's action, every layer rendered. `--grow=N` first
plays N steps with the scripted agent (which builds up to about 190 units on
BuildMarines), so the timed steps start from a crowded state.
Prints agent steps per second (best of `--rounds`) and the ratio.

    python scripts/leading_slots_ab.py --map=BuildMarines --size=64 --num_envs=64
"""

from __future__ import annotations

import time

import jax
import numpy as np
from absl import app, flags

from sc2jax.environment import Simulator
from sc2jax.environment.minigames import get_map
from sc2jax.environment.specs import ObservationFormat
from sc2jax.environment.state import slots_in_use
from sc2jax.experiments.evaluation import make_policy

FLAGS = flags.FLAGS
flags.DEFINE_string("map", "BuildMarines", "BuildMarines or CollectMineralsAndGas.")
flags.DEFINE_integer("size", 64, "Screen and minimap resolution.")
flags.DEFINE_integer("num_envs", 64, "Environments.")
flags.DEFINE_integer("steps", 32, "Agent steps per timed call.")
flags.DEFINE_integer("rounds", 5, "Timed calls per engine.")
flags.DEFINE_integer("grow", 0, "Scripted-agent steps played before timing.")


def _start(fmt: ObservationFormat, n: int):
    """The batch's state: fresh, or after `--grow` scripted steps."""
    keys = jax.random.split(jax.random.PRNGKey(0), n)
    if not FLAGS.grow:
        return jax.vmap(Simulator(FLAGS.map, fmt).reset)(keys)[0]
    # The scripted agent reads every unit.
    seen = ObservationFormat(screen_size=FLAGS.size, minimap_size=FLAGS.size,
                             use_feature_units=True, max_units=get_map(FLAGS.map).num_slots)
    sim = Simulator(FLAGS.map, seen)
    policy = make_policy("scripted", FLAGS.map, seen)
    state, ts = jax.vmap(sim.reset)(keys)

    def body(carry, key):
        state, ts = carry
        action = jax.vmap(policy)(jax.random.split(key, n), ts.observation)
        return jax.vmap(sim.step)(state, action), None

    play = jax.jit(lambda s, t: jax.lax.scan(body, (s, t), jax.random.split(
        jax.random.PRNGKey(1), FLAGS.grow))[0][0])
    return play(state, ts)


def _rollout(sim: Simulator, n: int):
    policy = make_policy("random", sim.map_name, sim.fmt)

    def run(state, key):
        def body(carry, key):
            state, obs = carry
            action = jax.vmap(policy)(jax.random.split(key, n), obs)
            state, ts = jax.vmap(sim.step)(state, action)
            return (state, ts.observation), None

        carry = (state, jax.vmap(sim.observe)(state))
        return jax.lax.scan(body, carry, jax.random.split(key, FLAGS.steps))[0]

    return jax.jit(run)


def main(argv):
    del argv
    n = FLAGS.num_envs
    fmt = ObservationFormat(screen_size=FLAGS.size, minimap_size=FLAGS.size)
    state = _start(fmt, n)
    in_use = np.asarray(jax.vmap(lambda u: slots_in_use(u.alive))(state.units))
    print(f"{FLAGS.map}, {FLAGS.size}², {n} environments, after {FLAGS.grow} scripted "
          f"steps: slots in use {in_use.min()}-{in_use.max()}")
    leading, every = Simulator(FLAGS.map, fmt), Simulator(FLAGS.map, fmt, use_slot_sizes=False)
    runs = {"leading slots": _rollout(leading, n), "all slots": _rollout(every, n)}
    for run in runs.values():
        jax.block_until_ready(run(state, jax.random.PRNGKey(2)))
    times = {name: [] for name in runs}
    for r in range(FLAGS.rounds):
        for name, run in runs.items():
            start = time.perf_counter()
            jax.block_until_ready(run(state, jax.random.PRNGKey(3 + r)))
            times[name].append(time.perf_counter() - start)
    for name, t in times.items():
        print(f"{name:14s} {n * FLAGS.steps / min(t):9,.0f} agent steps/s "
              f"(median {n * FLAGS.steps / np.median(t):,.0f})")
    best = {name: min(t) for name, t in times.items()}
    medians = {name: float(np.median(t)) for name, t in times.items()}
    print(f"leading / all: {best['all slots'] / best['leading slots']:.2f}x "
          f"(medians {medians['all slots'] / medians['leading slots']:.2f}x)")


if __name__ == "__main__":
    app.run(main)
