"""The simulator's built-in AI (`computer`) and the raw commands it gives
(`actions.apply_raw`): its levels, a raw command's selection and effect, and a whole
game in which the Hard computer builds its base and army and destroys a passive
player's (the game's outcome and rewards included).

The game runs Acropolis on 256 slots at 16 game loops a step with a 16² observation
without unit lists, in one jitted loop, in the slow tier (50 s on 2 cores).
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS
from sc2jax.environment.engine import computer
from sc2jax.environment.engine.actions import RawCommand, apply_raw
from sc2jax.environment.engine.rules.research import Research
from sc2jax.environment.engine.rules.state import NO_TARGET, Order, Outcome, Owner
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.dense import to_dense
from sc2jax.environment.interface.players import Difficulty
from sc2jax.environment.interface.protocol_enums import ActionResult
from sc2jax.environment.interface.specs import ObservationFormat
from tests.environment.helpers import SMALL

F = FUNCTIONS


def test_levels_grow_stronger():
    levels = [computer.LEVELS[d] for d in sorted(computer.LEVELS)]
    assert [lvl.period for lvl in levels] == sorted((lvl.period for lvl in levels),
                                                    reverse=True)
    for field in ("workers", "barracks", "refineries", "supply_margin", "wave"):
        values = [getattr(lvl, field) for lvl in levels]
        assert values == sorted(values), field
    assert computer.level(5) == computer.LEVELS[Difficulty.hard]
    with pytest.raises(ValueError, match=r"computer plays difficulties \['very_easy', "
                                         r"'easy', 'medium', 'hard'\], got 10"):
        computer.level(10)
    with pytest.raises(ValueError, match="computer plays the other player of a melee map"):
        Simulator("MoveToBeacon", SMALL, computer=1)
    with pytest.raises(ValueError, match="computer plays difficulties"):
        Simulator("Acropolis", SMALL, computer=8)


def test_structure_sites_are_a_ring_nearest_first():
    length = np.linalg.norm(computer.SITES, axis=-1)
    assert (np.diff(length) >= 0).all() and length.min() >= 6 and length.max() <= 16


TINY = ObservationFormat(screen_size=16, minimap_size=16)


@functools.cache
def game_sim():
    return Simulator("Acropolis", TINY, step_mul=16, score_index=-1, use_slot_sizes=False,
                     num_slots=256, computer=Difficulty.hard)


@pytest.mark.slow
def test_a_raw_command_selects_its_units_and_commands_them():
    sim = game_sim()
    state = sim._initial_state(jax.random.PRNGKey(0))
    units = jax.device_get(state.units)
    scvs = units.alive & (units.owner == Owner.SELF) & (units.type == UnitType.SCV)
    field = int(np.flatnonzero(units.alive & (units.type == UnitType.MINERAL_FIELD))[0])
    apply = jax.jit(functools.partial(apply_raw, renderer=sim.renderer, economy=True))
    gather = RawCommand(function=jnp.int32(F.Harvest_Gather_screen.id),
                        units=jnp.asarray(scvs), point=jnp.asarray(units.pos[field]),
                        target=jnp.int32(field), queued=jnp.int32(0))
    after = jax.device_get(apply(state, gather))
    np.testing.assert_array_equal(after.units.selected, scvs)
    assert (after.units.orders[scvs, 0] == Order.GATHER).all()
    assert (after.units.order_unit[scvs, 0] == field).all()
    assert int(after.last_action) == F.Harvest_Gather_screen.id
    # A command the units cannot take is not supported, as a feature action.
    build = gather._replace(function=jnp.int32(F.Train_Marine_quick.id),
                            target=jnp.int32(NO_TARGET))
    after = jax.device_get(apply(state, build))
    assert int(after.action_result) == ActionResult.NotSupported
    assert int(after.minerals) == 50


@pytest.mark.slow
def test_the_hard_computer_builds_an_army_and_destroys_a_passive_player():
    sim = game_sim()
    noop = to_dense(F.no_op(), TINY.types)

    def play(key):
        """The game to its end or 1,000 steps (16,000 game loops: 11.9 minutes at
        Faster speed), and the types the computer had complete on the way."""
        state, ts = sim.reset(key)

        def one(carry):
            state, ts, seen, count = carry
            state, ts = sim.step(state, noop)
            units = state.units
            theirs = units.alive & (units.owner == Owner.ENEMY) & units.complete
            seen = seen | jnp.any(theirs[:, None] & (units.type[:, None] == jnp.arange(
                len(UnitType))), axis=0)
            return state, ts, seen, count + 1

        def running(carry):
            return (carry[1].step_type != 2) & (carry[3] < 1000)

        return jax.lax.while_loop(running, one, (state, ts, jnp.zeros(len(UnitType), bool),
                                                 jnp.int32(0)))

    # Compiled at XLA's usual optimisation (the suite's default, level 0, runs this long
    # game about ten times as slowly: tests/conftest.py).
    key = jax.random.PRNGKey(1)
    compiled = jax.jit(play).lower(key).compile({"xla_backend_optimization_level": 2})
    state, ts, seen, _ = jax.device_get(compiled(key))
    seen = {UnitType(t) for t in np.flatnonzero(seen)}
    assert {UnitType.SUPPLY_DEPOT, UnitType.BARRACKS, UnitType.REFINERY,
            UnitType.BARRACKS_TECH_LAB, UnitType.MARINE, UnitType.MARAUDER} <= seen
    assert bool(state.other.researched[Research.STIMPACK])
    assert int(state.other.score_cumulative[5]) > 0  # collected_vespene
    # The player, with no structure left, has lost: its reward is -1, the game over.
    assert int(state.outcome) == Outcome.DEFEAT
    assert int(ts.step_type) == 2 and float(ts.reward) == -1.0 and float(ts.discount) == 0.0
    units = state.units
    assert not (units.alive & (units.owner == Owner.SELF)
                & (units.type == UnitType.COMMAND_CENTER)).any()
    assert int(state.game_loop) < 16_000
