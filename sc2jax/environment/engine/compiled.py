"""The compile caches: one `Simulator` per configuration, and its compiled reset and step,
shared by every environment (dm_env shells, the SC2-API server, training) in a process."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.engine.xla.devices import over_devices
from sc2jax.environment.interface import specs


@functools.cache
def compiled(sim: Simulator, batched: bool, devices: tuple[jax.Device, ...] = ()):
    """Compiled reset and step, shared by every environment of the same simulator.

    Batched, they take a leading environment axis on every argument but the `EnvParams`
    (shared by all). With more than one of `devices`, that axis is split over them.
    """
    reset, step = sim.reset, sim.step
    if batched and len(devices) > 1:
        reset, step = (_split_over(fn, devices) for fn in (reset, step))
    elif batched:
        reset = jax.vmap(reset, in_axes=(0, None))
        step = jax.vmap(step, in_axes=(0, 0, None))
    return jax.jit(reset), jax.jit(step)


@functools.cache
def compiled_both(sim: Simulator):
    """Compiled `reset_both` and `step_both` of a two-player map (one game), shared."""
    return jax.jit(sim.reset_both), jax.jit(sim.step_both)


def _split_over(fn, devices):
    """`fn(*per_env, params)` vmapped over `per_env` and split over `devices`; the shared
    `params` are broadcast to each environment, as `over_devices` splits every argument."""
    split = over_devices(jax.vmap(fn), devices)

    def run(*args):
        *per_env, params = args
        num_envs = jax.tree_util.tree_leaves(per_env)[0].shape[0]
        params = jax.tree_util.tree_map(
            lambda p: jnp.broadcast_to(p, (num_envs, *np.shape(p))), params)
        return split(*per_env, params)

    return run


def simulator(map_name: str, fmt: specs.ObservationFormat, step_mul: int, score_index: int,
              score_multiplier: float, discount: float,
              allow_cheating_layers: bool, use_slot_sizes: bool = True,
              num_slots: int | None = None, computer: int = 0) -> Simulator:
    """One `Simulator` per configuration, so environments share compiled code (however
    the arguments are passed)."""
    return _simulator(map_name, fmt, step_mul, score_index, score_multiplier, discount,
                      allow_cheating_layers, use_slot_sizes, num_slots, computer)


@functools.cache
def _simulator(map_name, fmt, step_mul, score_index, score_multiplier, discount,
               allow_cheating_layers, use_slot_sizes, num_slots, computer) -> Simulator:
    return Simulator(map_name=map_name, fmt=fmt, step_mul=step_mul, score_index=score_index,
                     score_multiplier=score_multiplier, discount=discount,
                     allow_cheating_layers=allow_cheating_layers,
                     use_slot_sizes=use_slot_sizes, num_slots=num_slots, computer=computer)
