"""Melee matches against the simulator's built-in AI: whole games in one jitted loop,
vmapped over games, for calibrating its levels (`scripts/computer_games.py`).

The other player is the computer at a level; the player is one of:

- `IDLE`: does nothing;
- `RANDOM`: the paper's random policy over the feature interface (`random_action`);
- `SCRIPTED`: the computer's own script at a level of the player's (a difficulty, or
  `RUSH`: a scripted rush of 2 Barracks and 14 SCVs attacking in waves of 5 Marines
  from 3.5 minutes).

Levels are traced values (`computer.Level` of arrays), so one compiled program plays
every pairing.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from sc2jax.environment.agents.random_agent import random_action
from sc2jax.environment.engine import computer
from sc2jax.environment.engine.actions import apply_raw
from sc2jax.environment.engine.rules import players
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.dense import zeros

IDLE, RANDOM, SCRIPTED = 0, 1, 2
RUSH = computer.Level(workers=14, barracks=2, refineries=0, tech=False, supply_margin=3,
                      wave=5, first_attack=int(3.5 * computer.LOOPS_PER_MINUTE), retreat=0.0,
                      period=1, scout_at=0, bank=300, expand_at=0)
"""The scripted rush: 2 Barracks (more while 300 minerals pile up), 14 SCVs, and from
3.5 minutes on waves of 5 Marines that the Marines trained meanwhile join."""


def as_arrays(level: computer.Level) -> computer.Level:
    """A `Level` of arrays (traced values: one program for every level)."""
    return computer.Level(*(jnp.asarray(v) for v in level))


def play(sim: Simulator, key, kind, mine: computer.Level, theirs: computer.Level,
         max_steps: int):
    """One melee game, to its end or `max_steps` agent steps.

    Args:
      sim: a melee map's simulator, with `score_index=-1`.
      key: the game's RNG key.
      kind: int32 `IDLE`, `RANDOM` or `SCRIPTED`: the player.
      mine: the player's `Level` (as arrays) where `SCRIPTED`.
      theirs: the computer's `Level` (as arrays), or None where the simulator plays its
        own computer (`Simulator.computer`).
      max_steps: (static) the most agent steps.

    Returns:
      (the last state, the player's last timestep).
    """
    if sim.game.players != 2 or (theirs is None) != bool(sim.computer):
        raise ValueError("play needs a melee map's simulator, and the computer's level "
                         "exactly where the simulator has no computer of its own")
    noop = jax.tree.map(jnp.asarray, zeros())
    key, reset_key = jax.random.split(key)
    state, ts = sim.reset(reset_key)
    buildable = sim.renderer.buildable
    apply = lambda s, c: apply_raw(s, c, sim.renderer, sim.card_table, economy=True)  # noqa: E731

    def one(carry):
        state, ts, key, steps = carry
        key, act_key = jax.random.split(key)
        start, other_start = sim.game.start_cameras(state.map_state)
        natural, other_natural = sim.game.naturals(state.map_state)
        if theirs is not None:  # Else the simulator's step has its computer act.
            seen = players.mirror(state)
            state = players.mirror(apply(seen, computer.command(
                seen, theirs, other_start, start, other_natural, buildable)))
        scripted = apply(state, computer.command(state, mine, start, other_start, natural,
                                                 buildable))
        state = jax.tree.map(lambda a, b: jnp.where(kind == SCRIPTED, a, b), scripted, state)
        randomly = random_action(act_key, ts.observation["available_actions_mask"],
                                 sim.fmt.types)
        action = jax.tree.map(lambda a, b: jnp.where(kind == RANDOM, a, b), randomly, noop)
        state, ts = sim.step(state, action)
        return state, ts, key, steps + 1

    def running(carry):
        return (carry[1].step_type != 2) & (carry[3] < max_steps)

    state, ts, _, _ = jax.lax.while_loop(running, one, (state, ts, key, jnp.int32(0)))
    return state, ts
