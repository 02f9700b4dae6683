"""Fitting rollouts in memory: what a rollout takes, what is free, and grouping rollouts
that are held at once (the simulator benchmark times each environment count's rollouts
together, and their carries hold every environment's observation)."""

from __future__ import annotations

from collections.abc import Sequence

import jax
import jax.numpy as jnp

from sc2jax.environment import Simulator

FOOTPRINT = 3
"""A rollout's memory as a multiple of its carry's bytes: the carry, and the next carry and
temporaries while it runs (on the CPU at 1,024 environments of 64² layers, one rollout's
process peaked at 2.2x its carry for MoveToBeacon and 4.1x for BuildMarines, a few hundred
MB of which is the process itself)."""
MEMORY_FRACTION = 0.8
"""The part of the free memory that the rollouts timed together may take."""


def carry_bytes(sim: Simulator) -> int:
    """Bytes of one environment's share of a rollout's carry (its state and last timestep;
    a rollout of B environments carries B times this). From shapes: nothing is computed."""
    shapes = jax.eval_shape(sim.reset, jax.ShapeDtypeStruct((2,), jnp.uint32))
    return sum(x.size * x.dtype.itemsize for x in jax.tree_util.tree_leaves(shapes))


def free_memory(device: jax.Device) -> int | None:
    """Bytes free for new buffers: an accelerator's allocator limit less what it holds, or
    on a CPU the host's available memory; None where unknown."""
    stats = device.memory_stats() if device.platform != "cpu" else None
    if stats and "bytes_limit" in stats:
        return stats["bytes_limit"] - stats.get("bytes_in_use", 0)
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def footprint(carry: int, devices: Sequence[jax.Device]) -> int:
    """Bytes a rollout with a carry of `carry` bytes takes on the first of its devices (an
    estimate, `FOOTPRINT`); host devices share one memory, so a CPU rollout takes it all."""
    share = 1 if devices[0].platform == "cpu" else len(devices)
    return FOOTPRINT * carry // share


def memory_groups(sizes: Sequence[int], budget: int | None) -> list[list[int]]:
    """Splits items, in order, into consecutive groups whose sizes sum to at most `budget`
    (an item over the budget alone makes a group of its own).

    Args:
      sizes: each item's bytes.
      budget: bytes a group may take (None: no limit, one group).

    Returns:
      Lists of item indices.
    """
    groups, used = [], 0
    for i, size in enumerate(sizes):
        if not groups or (budget is not None and used + size > budget):
            groups.append([])
            used = 0
        groups[-1].append(i)
        used += size
    return groups
