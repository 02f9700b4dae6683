"""The simulator's built-in AI (`computer`): its levels, and a whole game between two
scripted AIs, the Hard level's script against the VeryEasy computer (the game's outcome
and rewards included). Raw commands (`actions.apply_raw`) are checked with the raw
interface, in `test_raw_actions.py`.

The game runs Acropolis on 256 slots (fewer than the Hard script's 38 SCVs and army
need late on: the test's time) at 16 game loops a step with a 16² observation without unit
lists, in one jitted loop (`agents.melee_matches`), in the slow tier.
"""

import functools

import jax
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS
from sc2jax.environment.agents import melee_matches
from sc2jax.environment.engine import computer
from sc2jax.environment.engine.rules.research import Research
from sc2jax.environment.engine.rules.state import Outcome, Owner
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.observation_tables import ScoreCumulative
from sc2jax.environment.interface.players import Difficulty
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


def test_the_opponent_asked_for_is_a_terran_or_random_of_build_random():
    assert computer.opponent("terran", "easy") == Difficulty.easy
    assert computer.opponent("random", 5, "random") == Difficulty.hard
    assert computer.opponent("terran", Difficulty.medium) == Difficulty.medium
    for race, build in (("zerg", "random"), ("terran", "rush"), (None, "random")):
        with pytest.raises(ValueError, match=f"got race {race!r}, build {build!r}"):
            computer.opponent(race, "easy", build)
    with pytest.raises(ValueError, match="plays difficulties .*, got 'harder'"):
        computer.opponent("terran", "harder")
    with pytest.raises(ValueError, match="plays difficulties .*, got 'nope'"):
        computer.opponent("terran", "nope")


def test_structure_sites_are_a_ring_nearest_first():
    length = np.linalg.norm(computer.SITES, axis=-1)
    assert (np.diff(length) >= 0).all() and length.min() >= 6 and length.max() <= 16


TINY = ObservationFormat(screen_size=16, minimap_size=16)


@pytest.mark.slow
def test_a_game_between_the_hard_script_and_the_very_easy_computer():
    """The player plays the Hard level's script (`melee_matches`), the simulator its
    VeryEasy computer, to the end: the Hard side wins (as in 2 of 2 calibration games,
    docs/full_game.md) and the rewards say so."""
    sim = Simulator("Acropolis", TINY, step_mul=16, score_index=-1, use_slot_sizes=False,
                    num_slots=256, computer=Difficulty.very_easy)
    hard = melee_matches.as_arrays(computer.LEVELS[Difficulty.hard])
    play = functools.partial(melee_matches.play, sim, kind=melee_matches.SCRIPTED,
                             mine=hard, theirs=None, max_steps=1000)
    # Compiled at XLA's usual optimisation (the suite's default, level 0, runs this long
    # game about ten times as slowly: tests/conftest.py).
    key = jax.random.PRNGKey(1)
    compiled = jax.jit(play).lower(key).compile({"xla_backend_optimization_level": 2})
    state, ts = jax.device_get(compiled(key))
    assert int(state.outcome) == Outcome.VICTORY
    assert int(ts.step_type) == 2 and float(ts.reward) == 1.0 and float(ts.discount) == 0.0
    units = state.units
    assert not (units.alive & (units.owner == Owner.ENEMY)
                & (units.type == UnitType.COMMAND_CENTER)).any()
    # Both sides played: the Hard script took gas and Stimpack, the computer spent on a
    # Supply Depot and a Barracks at least.
    assert bool(state.researched[Research.STIMPACK])
    assert int(state.score_cumulative[ScoreCumulative.collected_vespene]) > 0
    assert int(state.other.score_cumulative[ScoreCumulative.spent_minerals]) >= 250
    assert int(state.game_loop) < 16_000
    # The Hard script took its natural expansion (a Command Center stands there).
    natural = np.asarray(sim.game.naturals(state.map_state)[0])
    mine = units.alive & (units.owner == Owner.SELF)
    there = np.linalg.norm(np.asarray(units.pos) - natural, axis=-1) < 1.0
    assert (mine & (units.type == UnitType.COMMAND_CENTER) & there).any()
