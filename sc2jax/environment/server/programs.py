"""The server's compiled programs: one set per map, observation format and opponent, a
bounded number of sets kept.

A set compiles once, at the first `join_game` (or `start_replay`) of its map and format,
and runs every step count: the count is a run-time argument of the step program
(`Simulator.step(..., loops=)`), so `RequestStep.count` never compiles. At most
`MAX_FORMATS` sets are kept; joining with a new one drops the least recently used (its
compiled code is freed with it, and a later join of that format compiles it again).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import jax

from sc2jax.environment.engine.observation import api_units
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface import specs

MAX_FORMATS = 4
"""The most (map, format) program sets kept. With 4, the server stayed under 1.3 GB over
1,000 requests cycling six formats on the CPU (docs/server.md); a client that keeps one
format, as PySC2's do, compiles once."""
STEP_MUL = 8
"""The simulator's nominal step_mul (every step passes its own count; 8, PySC2's default,
only names the simulator)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Programs:
    """One map and format's jitted programs.

    Attributes:
      sim: the simulator they run.
      reset: (key, params) -> (state, TimeStep).
      step: (state, action, params, loops int32) -> (state, TimeStep): apply the action
        and run `loops` game loops.
      act: (state, action) -> state: apply an action without advancing.
      units: state -> the SC2 API's unit rows (`observation.api_units`).
    """

    sim: Simulator
    reset: Callable
    step: Callable
    act: Callable
    units: Callable


@functools.lru_cache(maxsize=MAX_FORMATS)
def programs(map_name: str, fmt: specs.ObservationFormat, computer: int = 0,
             num_slots: int | None = None) -> Programs:
    """The program set of `map_name` at `fmt`, with the simulator's `computer` and
    `num_slots` on ladder maps (compiled at first call; at most `MAX_FORMATS` sets
    cached, least recently used dropped)."""
    sim = Simulator(map_name=map_name, fmt=fmt, step_mul=STEP_MUL, computer=computer,
                    num_slots=num_slots)
    return Programs(
        sim=sim, reset=jax.jit(sim.reset),
        step=jax.jit(lambda state, action, params, loops: sim.step(state, action, params,
                                                                  loops=loops)),
        act=jax.jit(sim.act), units=jax.jit(lambda state: api_units(state, sim.renderer)))
