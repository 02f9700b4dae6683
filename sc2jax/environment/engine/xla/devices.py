"""Environments split over devices: each device steps its share of a batch.

A batched function of environments that never exchange data (`jax.vmap(sim.step)`, or a
rollout that scans it with a key per environment) runs unchanged on a slice of the batch.
`over_devices` gives each device B / D of the B environments, so the devices step at the
same time.

On a CPU this is what uses its cores. An agent step of the simulator is about a
thousand small kernels that run one after another, mostly on one thread, so one device
leaves the other cores idle. JAX makes one host device per core when asked before its
backends start (`use_cpu_cores`, which `python -m sc2jax.experiments.benchmark` calls). On
an accelerator the devices are the local GPUs or TPUs.

    step = jax.jit(over_devices(jax.vmap(sim.step)))
    states, timesteps = step(states, actions)  # every leaf [B, ...], B a multiple of D

Each environment's arithmetic is the same wherever it runs, but XLA compiles the program
for B / D environments, and its fusion choices for another shape can round differently.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence

import jax
import numpy as np
from jax.sharding import Mesh, PartitionSpec

AXIS = "envs"
"""The mesh axis the environments are split along."""


def over_devices(batched_fn: Callable, devices: Sequence[jax.Device] | None = None) -> Callable:
    """`batched_fn` with the leading (environment) axis of its arguments and results split
    evenly over `devices`.

    Args:
      batched_fn: maps pytrees whose every leaf is [B, ...] to pytrees whose every leaf is
        [B, ...], environment b of the results depending only on environment b of the
        arguments (so each device can compute its own slice).
      devices: the devices, in order; None for `jax.local_devices()`. With one device,
        `batched_fn` is returned unchanged.

    Returns:
      A function of the same arguments. It raises ValueError, before any computation, if
      a leaf has no leading axis or its B is not a multiple of the number of devices.
      Its results are sharded over the devices along the environment axis, so a later
      call takes them without a transfer; jit it to compile once.

    Raises:
      ValueError: `devices` is empty.
    """
    devices = list(jax.local_devices() if devices is None else devices)
    if not devices:
        raise ValueError("devices must name at least one device, got none")
    if len(devices) == 1:
        return batched_fn
    mesh = Mesh(np.asarray(devices), (AXIS,))
    # check_vma=False: the simulator's lazy branches (`lax.cond`) mix values that differ per
    # device with constants, which is sound here (nothing is exchanged between devices)
    # but fails shard_map's type check.
    split = jax.shard_map(batched_fn, mesh=mesh, in_specs=PartitionSpec(AXIS),
                          out_specs=PartitionSpec(AXIS), check_vma=False)

    def run(*args):
        for path, leaf in jax.tree_util.tree_leaves_with_path(args):
            shape = np.shape(leaf)
            if not shape or shape[0] % len(devices):
                raise ValueError(
                    f"over {len(devices)} devices every argument needs a leading environment "
                    f"axis that is a multiple of {len(devices)}; argument "
                    f"{jax.tree_util.keystr(path)} has shape {shape}")
        return split(*args)

    return run


def first_devices(count: int, num_envs: int, name: str = "num_devices") -> tuple:
    """The first `count` (>= 1) local devices, to split `num_envs` environments over.

    Raises:
      ValueError: for more devices than this process has (`name` names the setting), or
        environments that do not split evenly over them.
    """
    local = jax.local_devices()
    if count > len(local):
        raise ValueError(f"{name}={count}, but this process has {len(local)} "
                         f"({local[0].platform}); on a CPU, more host devices are made "
                         f"with `use_cpu_cores`")
    if num_envs % count:
        raise ValueError(f"num_envs={num_envs} does not split evenly over {count} "
                         f"devices; use a multiple of {count}")
    return tuple(local[:count])


def use_cpu_cores(at_least: int = 0) -> None:
    """Gives the CPU platform one host device per core (or `at_least`, if more).

    Call it before JAX starts its backends (before any computation); it changes nothing on
    an accelerator, whose devices stay the local devices.

    Raises:
      RuntimeError: JAX's backends have already started.
    """
    jax.config.update("jax_num_cpu_devices", max(os.cpu_count() or 1, at_least))


SMALL_LOOP_OPTION = "xla_cpu_small_while_loop_byte_threshold"
SMALL_LOOP_BYTES = 1_000_000
"""`compile_small_loops_whole`'s default: MoveToBeacon's game loop at 16 environments fits
under it, and at 64 does not."""


def compile_small_loops_whole(max_bytes: int = SMALL_LOOP_BYTES) -> None:
    """Lets XLA's CPU backend compile a while loop that touches at most `max_bytes` into
    one kernel (its `xla_cpu_small_while_loop_byte_threshold`, 1 KB by default).

    By default each operation of a loop's body is a kernel of its own, dispatched one
    after another: about 1,300 of them in an agent step's game loops on MoveToBeacon at
    one environment. A loop whose body XLA can compile whole (no scatter, sort or
    custom call: the game loops of the first three mini-games) runs as one kernel
    instead; at one environment an agent step then runs 1.03-1.84x faster
    (docs/benchmarks.md). The same game, though not always the same bits: compiled as
    one kernel, a loop's float arithmetic can round differently in its last bit
    (FindAndDefeatZerglings at one environment: the same episodes for 1,000 agent steps,
    the marines' positions 1e-5 apart by 2,000). Each compiled program is still
    deterministic. It changes the whole process's CPU compilation, so it is the
    caller's choice (`python -m sc2jax.experiments.benchmark` makes it); a value already
    in `XLA_FLAGS` is kept.

    Call it before JAX starts its backends (before any computation).

    Raises:
      RuntimeError: JAX's backends have already started.
      ValueError: max_bytes is not a positive int.
    """
    if isinstance(max_bytes, bool) or not isinstance(max_bytes, int) or max_bytes < 1:
        raise ValueError(f"max_bytes must be a positive int, got {max_bytes!r}")
    from jax._src import xla_bridge  # JAX has no public check; XLA reads the flags once.
    if xla_bridge.backends_are_initialized():
        raise RuntimeError("compile_small_loops_whole must be called before JAX starts its "
                           "backends (before any computation): XLA reads XLA_FLAGS once")
    flags = os.environ.get("XLA_FLAGS", "")
    if SMALL_LOOP_OPTION in flags:
        return
    option, extra = f"{SMALL_LOOP_OPTION}={max_bytes}", "--xla_backend_extra_options="
    if extra in flags:  # One comma-separated list of backend options.
        flags = flags.replace(extra, f"{extra}{option},", 1)
    else:
        flags = f"{flags} {extra}{option}".strip()
    os.environ["XLA_FLAGS"] = flags


def device_sets(num_envs: int, counts: Sequence[int]) -> list[list[jax.Device]]:
    """The local devices to split `num_envs` environments over, one list per device count
    in `counts` (0: every local device). A count that does not divide `num_envs` becomes
    one device, and repeated lists are dropped.

    Raises:
      ValueError: a count is more than the local devices.
    """
    local = jax.local_devices()
    sets = []
    for count in counts:
        count = count or len(local)
        if count > len(local):
            raise ValueError(f"{count} devices asked for, but this process has {len(local)} "
                             f"({local[0].platform}); allowed: 0..{len(local)}")
        chosen = local[:count] if num_envs % count == 0 else local[:1]
        if chosen not in sets:
            sets.append(chosen)
    return sets
