"""The game's score: `score_cumulative` bookkeeping and the Blizzard score.

`score_cumulative` (observation_tables.ScoreCumulative) is kept in `EnvState`: index 0 is
the map's curriculum score (`EnvState.score`); the rest follow the game's definitions:

- collected_minerals / collected_vespene: resources the player's workers deposited;
- collection_rate_minerals / _vespene: the current income per real minute at Faster speed
  (1344 game loops), a moving average over about 10 game seconds;
- spent_minerals / spent_vespene: paid for units and structures, less refunds;
- total_value_units / total_value_structures: the cost of the player's living units
  and structures (unfinished ones included);
- killed_value_units: the cost of the enemy units killed;
- idle_worker_time / idle_production_time: game loops summed over idle SCVs and over
  complete producers (structures that train) with an empty queue.

The **Blizzard score** is the paper's (§3): the resources the player has, plus the value of
its units and structures alive or in progress (units and research queued included), plus
the cost of the research done (`research`).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.rules import research
from sc2jax.environment.engine.rules.production import queue_cost, trains
from sc2jax.environment.engine.rules.state import EnvState, Owner, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, Attribute
from sc2jax.environment.engine.xla.fusion import set_static
from sc2jax.environment.interface.observation_tables import ScoreCumulative as C

LOOPS_PER_RATE_MINUTE = 22.4 * 60
"""Game loops per real minute at Faster speed: the unit of the collection rates."""
RATE_SMOOTHING = 1.0 / 160.0
"""The moving average's weight per loop (a time constant of 10 game seconds)."""

_VALUE = (UNIT_DATA.mineral_cost + UNIT_DATA.vespene_cost).astype(np.int32)
_STRUCTURE = (UNIT_DATA.attributes & Attribute.STRUCTURE) > 0


def values(units: Units):
    """(units, structures, queued) int32: the cost of the player's living units, of its
    structures, and of what its queues hold (an upgrade its price, not its form's)."""
    own = units.alive & (units.owner == Owner.SELF)
    value = jnp.asarray(_VALUE)
    worth = value[units.type]
    structure = jnp.asarray(_STRUCTURE)[units.type]
    paid = jnp.sum(queue_cost(units.type[:, None], units.queue), axis=-1)
    queued = jnp.sum(jnp.where(own[:, None] & (units.queue != 0), paid, 0))
    return (jnp.sum(jnp.where(own & ~structure, worth, 0)),
            jnp.sum(jnp.where(own & structure, worth, 0)), queued)


def blizzard_score(state: EnvState):
    """int32: resources plus the value of units and structures alive or in progress, and
    of the research queued and done."""
    unit_value, structure_value, queued = values(state.units)
    return (state.minerals + state.vespene + unit_value + structure_value + queued
            + research.value(state.researched)).astype(jnp.int32)


def after_loop(state: EnvState, old_units: Units, died, minerals, vespene, spent):
    """The score after one game loop.

    Args:
      state: the state after the loop (units and resources updated).
      old_units: the units before the loop (to value the enemies that died).
      died: bool[N] units that died in the loop.
      minerals, vespene: float32 resources the player's workers deposited in the loop.
      spent: int32[2] minerals and vespene the player spent in the loop.

    Returns:
      The state with `score_cumulative` and `collection_rate` updated.
    """
    cumulative, rate = tally(state.units, old_units, state.score_cumulative,
                             state.collection_rate, died, minerals, vespene, spent)
    return state.replace(score_cumulative=cumulative, collection_rate=rate)


def tally(units: Units, old_units: Units, cumulative, rate, died, minerals, vespene, spent):
    """The player's `score_cumulative` (int32[13]) and `collection_rate` (float32[2])
    after a loop, from their values before it and the loop's units and events (as
    `after_loop`'s arguments). Returns (cumulative, rate)."""
    enemy_died = died & (old_units.owner == Owner.ENEMY)
    killed = jnp.sum(jnp.where(enemy_died, jnp.asarray(_VALUE)[old_units.type], 0))
    own = units.alive & (units.owner == Owner.SELF)
    idle_workers = jnp.sum(units.idle_workers)
    idle_producers = jnp.sum(units.complete & own & trains(units) & (units.queue[:, 0] == 0))
    income = jnp.stack([minerals, vespene]) * LOOPS_PER_RATE_MINUTE
    rate = rate + (income - rate) * RATE_SMOOTHING
    added = {C.killed_value_units: killed, C.collected_minerals: minerals.astype(jnp.int32),
             C.collected_vespene: vespene.astype(jnp.int32), C.spent_minerals: spent[0],
             C.spent_vespene: spent[1],
             C.idle_worker_time: idle_workers, C.idle_production_time: idle_producers}
    cumulative = set_static(cumulative, {
        **{int(i): cumulative[i] + v for i, v in added.items()},
        int(C.collection_rate_minerals): jnp.round(rate[0]).astype(jnp.int32),
        int(C.collection_rate_vespene): jnp.round(rate[1]).astype(jnp.int32)})
    return cumulative, rate


def after_step(state: EnvState) -> EnvState:
    """Sets the unit and structure values at the end of an agent step."""
    unit_value, structure_value, _ = values(state.units)
    return state.replace(score_cumulative=state.score_cumulative
                         .at[C.total_value_units].set(unit_value)
                         .at[C.total_value_structures].set(structure_value))
