"""Data-parallel training over a global device mesh: one process, or several joined by
`jax.distributed` (JAX's multi-controller runtime: every process runs the same program).

The environments of a `TrainState` are split over the mesh's devices (their leading
[B] axis, `AXIS`); the learner's state (parameters, optimiser state) and the actor's
PRNG key are replicated. The compiled step (`compiled_loop`) is the same program: given
global arrays so placed, XLA partitions it, each device stepping its own environments,
and the learner's mean over the batch becomes an all-reduce of the gradients, so the
parameters stay identical on every device of every process.

A run started the same way on every process (the same config and seed, so the same
initial state everywhere) is `place`d: each process keeps the parts its own devices
hold. On CPU, collectives between processes use gloo.
"""

from __future__ import annotations

import os
from typing import Any

import jax
import numpy as np
from jax.experimental import multihost_utils
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from sc2jax.environment.engine.xla.devices import AXIS
from sc2jax.experiments.training.compiled_loop import TrainState


def initialize(coordinator: str | None = None, num_processes: int | None = None,
               process_id: int | None = None) -> None:
    """Joins this process to the others (`jax.distributed.initialize`), before any other
    JAX work. Arguments left None are read from the cluster's environment (SLURM, Open
    MPI, Kubernetes...) as JAX reads them.

    Raises:
      ValueError: for a process id outside [0, num_processes), or a count below 1.
    """
    _check_process(process_id, num_processes)
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(coordinator_address=coordinator, num_processes=num_processes,
                               process_id=process_id)


_CLUSTERS = (("SLURM_PROCID", "SLURM_NTASKS"), ("OMPI_COMM_WORLD_RANK", "OMPI_COMM_WORLD_SIZE"))
"""The environment variables of this process's number and the process count, by cluster
(SLURM, Open MPI), as `jax.distributed` reads them."""


def cluster_process(process_id: int | None = None,
                    num_processes: int | None = None) -> tuple[int, int]:
    """(process id, number of processes): those given, else read from the cluster's
    environment (`_CLUSTERS`), else (0, 1).

    Raises:
      ValueError: for a process id outside [0, num_processes), or a count below 1.
    """
    for id_name, count_name in _CLUSTERS:
        if id_name in os.environ and count_name in os.environ:
            if process_id is None:
                process_id = int(os.environ[id_name])
            if num_processes is None:
                num_processes = int(os.environ[count_name])
    num_processes = 1 if num_processes is None else num_processes
    process_id = 0 if process_id is None else process_id
    _check_process(process_id, num_processes)
    return process_id, num_processes


def _check_process(process_id: int | None, num_processes: int | None) -> None:
    if num_processes is not None and num_processes < 1:
        raise ValueError(f"num_processes must be >= 1, got {num_processes!r}")
    if process_id is not None and num_processes is not None and not (
            0 <= process_id < num_processes):
        raise ValueError(f"process_id must be in [0, {num_processes}), got {process_id!r}")


def mesh(devices=None) -> Mesh:
    """A one-axis mesh over `devices` (default: every device of every process)."""
    return Mesh(np.asarray(jax.devices() if devices is None else devices), (AXIS,))


def per_process(count: int) -> list:
    """The first `count` devices of every process, in process order (every device of
    one process when it is the only one)."""
    by_process: dict[int, list] = {}
    for device in jax.devices():
        by_process.setdefault(device.process_index, []).append(device)
    return [d for p in sorted(by_process) for d in by_process[p][:count]]


def is_primary() -> bool:
    """Whether this is process 0, the one that writes a run's files."""
    return jax.process_index() == 0


def agree(flag: bool) -> bool:
    """Process 0's `flag` on every process (a broadcast; `flag` itself in one process):
    for decisions taken from a clock, such as when to checkpoint, that every process
    must take alike."""
    if jax.process_count() == 1:
        return flag
    return bool(multihost_utils.broadcast_one_to_all(np.bool_(flag)))


def shardings(state: TrainState, over: Mesh) -> TrainState:
    """The `NamedSharding` of each leaf of `state`: the actor's per-environment leaves
    split on their leading axis, its key and the whole learner replicated."""
    split, whole = NamedSharding(over, PartitionSpec(AXIS)), NamedSharding(over, PartitionSpec())
    actor = jax.tree.map(lambda _: split, state.actor)
    return TrainState(jax.tree.map(lambda _: whole, state.learner),
                      actor.replace(key=jax.tree.map(lambda _: whole, state.actor.key)))


def place(state: TrainState, over: Mesh) -> TrainState:
    """`state`, which every process computed alike, as global arrays on `over`: each
    process keeps the parts its devices hold.

    Raises:
      ValueError: when the environments do not split evenly over the devices.
    """
    num_envs = len(state.actor.episode_return)
    if num_envs % over.size:
        raise ValueError(f"{num_envs} environments do not split evenly over {over.size} "
                         f"devices; use a multiple of {over.size}")

    def put(leaf, sharding):
        host = np.asarray(leaf)
        return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])

    return jax.tree.map(put, state, shardings(state, over))


def barrier(name: str) -> None:
    """Waits until every process has reached the barrier `name` (nothing in one process)."""
    if jax.process_count() > 1:
        multihost_utils.sync_global_devices(name)


def gather(tree: Any) -> Any:
    """`tree`'s global arrays as numpy on every process (an all-gather across processes;
    a plain copy in one process)."""
    if jax.process_count() == 1:
        return jax.tree.map(np.asarray, tree)
    return multihost_utils.process_allgather(tree, tiled=True)
