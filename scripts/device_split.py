r"""Acting beside learning on two devices (`DeviceActor`) against the compiled loop on one.

    python scripts/device_split.py --updates=40 [--cpu_devices=2] [--num_envs=16 ...]

Times, in one process and in turn, `--updates` updates of the same config (the quick
start's settings with V-trace and --num_envs environments, K = 16):

- the compiled loop: acting, then learning, on device 0;
- the split loop with the actor on device 0 too (acting and learning in two threads);
- the split loop with the actor on device 1 and the learner on device 0.

and prints agent steps/s of each, after one compiling update. On a CPU,
--cpu_devices=2 makes two XLA devices of the same cores.
"""

from __future__ import annotations

import argparse
import os
import sys
import time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--updates", type=int, default=40)
    parser.add_argument("--num_envs", type=int, default=16)
    parser.add_argument("--cpu_devices", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    if args.updates < 1 or args.repeats < 1:
        sys.exit("error: --updates and --repeats must be >= 1")
    os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + " --xla_force_host_platform_"
                               f"device_count={args.cpu_devices}")
    import dataclasses

    import jax

    from sc2jax.experiments.training.actor import make_unroll
    from sc2jax.experiments.training.device_actor import DeviceActor
    from sc2jax.experiments.training.host_actor import run_split_loop
    from sc2jax.experiments.training.presets import PRESETS
    from sc2jax.experiments.training.trainer import build

    if len(jax.devices()) < 2:
        sys.exit(f"error: two devices needed, found {jax.devices()}")
    config = dataclasses.replace(PRESETS["beacon_quickstart"].config, num_envs=args.num_envs,
                                 off_policy_correction="vtrace", updates_per_chunk=1)
    agent = build(config)
    learner_device, actor_device = jax.devices()[:2]
    steps = config.steps_per_update * args.updates

    def compiled() -> float:
        chunk = agent.chunk()
        state = jax.device_put(agent.initial_state(jax.random.PRNGKey(0)), learner_device)
        state = chunk(state)[0]
        jax.block_until_ready(state)
        start = time.perf_counter()
        for _ in range(args.updates):
            state = chunk(state)[0]
        jax.block_until_ready(state)
        return time.perf_counter() - start

    def split(device) -> float:
        unroll = make_unroll(agent.sim, agent.core, config.unroll_length)
        actor = DeviceActor(unroll, config.num_envs, jax.random.PRNGKey(0), device,
                            learner_device=learner_device)
        state = jax.device_put(agent.initial_learner(jax.random.PRNGKey(0)), learner_device)
        state, _ = run_split_loop(actor, agent.learner, state, 1)
        jax.block_until_ready(state)
        start = time.perf_counter()
        state, _ = run_split_loop(actor, agent.learner, state, args.updates)
        jax.block_until_ready(state)
        return time.perf_counter() - start

    settings = {"compiled loop, device 0": compiled,
                "split loop, actor and learner on device 0": lambda: split(learner_device),
                "split loop, actor on device 1, learner on device 0": lambda: split(actor_device)}
    print(f"{config.num_envs} environments x K = {config.unroll_length}, {args.updates} "
          f"updates, {jax.devices()}")
    for _ in range(args.repeats):
        for name, run in settings.items():
            print(f"| {name} | {steps / run():,.0f} |", flush=True)


if __name__ == "__main__":
    main()
