r"""The batched dm_env wrapper's throughput, on one device and split over several.

`make(map, num_envs=N, num_devices=D)` steps N environments per call, split over D
devices (on a CPU, host devices: `use_cpu_cores`). Each step here is what a user of the
wrapper pays: the random agent's action drawn (jitted) from the last observation's
`available_actions`, the action checked, one compiled step of every environment, and
every observation copied to the host. The device counts are timed round-robin (one
call of `--steps` steps each per round), so the machine's drift moves them alike.

    python scripts/wrapper_throughput.py --map=MoveToBeacon --num_envs=64 --devices=1,2
"""

from __future__ import annotations

import statistics
import time

import jax
from absl import app, flags

from sc2jax.environment import DenseAction, make
from sc2jax.environment.agents.random_agent import random_action
from sc2jax.environment.devices import use_cpu_cores

FLAGS = flags.FLAGS
flags.DEFINE_string("map", "MoveToBeacon", "Mini-game.")
flags.DEFINE_integer("num_envs", 64, "Environments per wrapper.")
flags.DEFINE_list("devices", ["1", "2"], "Device counts to compare (0: all).")
flags.DEFINE_integer("size", 64, "Screen and minimap resolution.")
flags.DEFINE_integer("steps", 50, "Wrapper steps per timed call.")
flags.DEFINE_integer("rounds", 7, "Timed calls per device count (the median is reported).")


def main(argv):
    del argv
    counts = [int(c) for c in FLAGS.devices]
    use_cpu_cores(max(counts))
    act = jax.jit(jax.vmap(random_action, in_axes=(0, 0, None)), static_argnums=2)
    envs, timesteps = {}, {}
    for count in counts:
        envs[count] = make(FLAGS.map, FLAGS.size, FLAGS.size, num_envs=FLAGS.num_envs,
                           seed=0, num_devices=count)
        timesteps[count] = envs[count].reset()
    key = jax.random.PRNGKey(0)

    def play(count):
        nonlocal key
        env = envs[count]
        for _ in range(FLAGS.steps):
            key, sub = jax.random.split(key)
            action = act(jax.random.split(sub, FLAGS.num_envs),
                         timesteps[count].observation["available_actions"],
                         env.simulator.fmt.types)
            timesteps[count] = env.step(DenseAction(*jax.device_get(action)))

    for count in counts:  # Warm-up: compiles.
        play(count)
    seconds = {count: [] for count in counts}
    for _ in range(FLAGS.rounds):
        for count in counts:
            start = time.perf_counter()
            play(count)
            seconds[count].append(time.perf_counter() - start)
    base = statistics.median(seconds[counts[0]])
    print(f"{FLAGS.map}, {FLAGS.num_envs} environments, {FLAGS.size}x{FLAGS.size}, every "
          f"layer; {jax.devices()[0].platform}, {FLAGS.rounds} rounds of {FLAGS.steps} steps")
    print("| Devices | Agent steps/s | × first row |\n|---:|---:|---:|")
    for count in counts:
        median = statistics.median(seconds[count])
        rate = FLAGS.steps * FLAGS.num_envs / median
        print(f"| {len(envs[count].devices)} | {rate:,.0f} | {base / median:.2f} |")


if __name__ == "__main__":
    app.run(main)
