"""Supervised training speed on a replay dataset: records per second of each network's
jitted Adam step (docs/benchmarks.md, "Replays").

    python scripts/replay_training_speed.py --dataset=DIR --networks=atari,fullyconv,arfullyconv

Each network trains on the same minibatches of the dataset's training split (read,
converted and copied to the device before timing, so only the update is timed): one
warm-up update (compilation), then the median of `--repeats` timings of `--updates`
updates each, to `block_until_ready`. Prints a markdown table.
"""

from __future__ import annotations

import argparse
import statistics
import time

import jax

from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.networks import make_network
from sc2jax.replay_sl.dataset import dataset_settings, loader
from sc2jax.replay_sl.learner import init, make_update, to_batch


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True)
    parser.add_argument("--networks", "--agents", dest="networks",
                        default="atari,fullyconv,arfullyconv")
    parser.add_argument("--batch_size", type=int, default=64)
    parser.add_argument("--updates", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    settings = dataset_settings(args.dataset)
    data = loader(args.dataset, "train", batch_size=args.batch_size, seed=0,
                  drop_remainder=True)
    batches = [jax.device_put(to_batch(data[i])) for i in range(args.updates)]
    fmt = ObservationFormat(screen_size=settings.screen_size,
                            minimap_size=settings.minimap_size)
    print(f"{jax.devices()[0].platform}, {len(jax.devices())} device(s); batch "
          f"{args.batch_size}; {settings.screen_size}² screen, {settings.minimap_size}² "
          f"minimap\n\n| network | ms per update | records/s |\n|---|---:|---:|")
    for agent in args.networks.split(","):
        network = make_network(agent, fmt)
        state = init(network, batches[0], jax.random.PRNGKey(0))
        update = make_update(network)
        state, metrics = update(state, batches[0])
        jax.block_until_ready(metrics)
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            for batch in batches:
                state, metrics = update(state, batch)
            jax.block_until_ready(metrics)
            times.append((time.perf_counter() - start) / len(batches))
        seconds = statistics.median(times)
        print(f"| {agent} | {1e3 * seconds:.0f} | {args.batch_size / seconds:.0f} |",
              flush=True)


if __name__ == "__main__":
    main()
