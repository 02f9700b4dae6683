"""Research (`research`): each research queued at its structure for the Terran data
table's cost and time, once per player, cancelled, and scored; and what each does:
Stimpack's stim, Combat Shield's health, Concussive Shells' slow, and Infantry Weapons
and Armor's damage and armour.

The queue scenes run CollectMineralsAndGas's step (as test_production); the combat
scenes the jitted game loop on hand-built units (as test_combat).
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS
from sc2jax.environment.engine import terran_data
from sc2jax.environment.engine.observation import api_units
from sc2jax.environment.engine.rules import production, research, score
from sc2jax.environment.engine.rules.dynamics import game_loop
from sc2jax.environment.engine.rules.research import Research
from sc2jax.environment.engine.rules.state import Order, Owner
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType, game_name
from sc2jax.environment.interface.protocol_enums import ActionResult
from tests.environment.helpers import small_sim

from .test_combat import units_of
from .test_production import (
    ADDON_SITE,
    CMAG,
    DEPOTS,
    PRODUCER_SITE,
    _with_addon,
    _with_units,
    act,
    available,
    pixel,
    result,
    slots,
    start,
    wait,
)

F = FUNCTIONS
MARINE_SITE = (33.0, 21.0)  # Open ground below the Command Center, clear of the fields.


def row(r):
    return terran_data.table()["upgrades"][research.GAME_NAME[r]]


def with_research(state, *done):
    researched = np.zeros(len(Research), bool)
    researched[list(done)] = True
    return state.replace(researched=jnp.asarray(researched))


def _at_structure(r):
    """A state with the structure researching `r` (a Barracks Tech Lab with its Barracks,
    or an Engineering Bay), a Marine, a bank of 1000 and 500, and the structure's site."""
    state, step = start()
    at = UnitType(int(research.AT[r]))
    if at == UnitType.BARRACKS_TECH_LAB:
        state = _with_units(state, [(UnitType.BARRACKS, PRODUCER_SITE)] + DEPOTS)
        state, site = _with_addon(state, at), ADDON_SITE
    else:
        state, site = _with_units(state, [(at, PRODUCER_SITE)] + DEPOTS), PRODUCER_SITE
    state = _with_units(state, [(UnitType.MARINE, MARINE_SITE)])
    state = state.replace(minerals=jnp.int32(1000), vespene=jnp.int32(500))
    return state, step, site


# The shortest in the fast tier; the others wait 220-320 steps each.
@pytest.mark.parametrize("r", [r if r == Research.CONCUSSIVE_SHELLS else pytest.param(
    r, marks=pytest.mark.slow) for r in Research], ids=lambda r: r.name)
def test_each_research_costs_and_takes_its_table_time(r):
    data = row(r)
    assert game_name(UnitType(int(research.AT[r]))) == data["researched_at"]
    state, step, site = _at_structure(r)
    state, ts = act(step, state, F.select_point("select", pixel(state, site)))
    button = F[research.BUTTON[r]]
    assert button.id in available(ts)
    state, ts = act(step, state, button("now"))
    assert result(ts) == 0
    assert (int(state.minerals), int(state.vespene)) == (1000 - data["minerals"],
                                                         500 - data["vespene"])
    # Once per player: the button goes while it is queued. The production panel shows
    # the research's ability, and no unit.
    assert button.id not in available(ts) and F.Cancel_Last_quick.id in available(ts)
    loops = int(data["research_time"])
    panel = ts.observation["production_queue"]
    assert panel[0].tolist() == [F[research.FUNCTION[r]].ability_id, 8 * 100 // loops]
    assert not ts.observation["build_queue"].any()
    # Queued at the start of a step of 8 loops, whose loops count: done in the step
    # where its research time is reached, and not before.
    assert loops % 8 == 0
    state, ts = wait(step, state, loops // 8 - 2)
    assert not bool(state.researched[r]) and not ts.observation["upgrades"].any()
    state, ts = wait(step, state, 1)
    assert np.flatnonzero(np.asarray(state.researched)).tolist() == [r]
    assert ts.observation["upgrades"].tolist()[:2] == [data["upgrade_id"], 0]
    assert button.id not in available(ts)
    assert not np.asarray(state.units.queue).any()
    # Combat Shield gives the Marine standing by 10 health, and its health ratio keeps
    # to the new most.
    marine = slots(state, UnitType.MARINE)[0]
    shielded = r == Research.COMBAT_SHIELD
    assert float(state.units.health[marine]) == (55.0 if shielded else 45.0)
    api = jax.device_get(api_units(state, small_sim(CMAG).renderer))
    assert api["health_max"][marine] == api["health"][marine]


def test_a_marine_trained_after_combat_shield_has_55_health():
    state, step, _ = _at_structure(Research.COMBAT_SHIELD)
    state = with_research(state, Research.COMBAT_SHIELD)
    state, _ = act(step, state, F.select_point("select", pixel(state, PRODUCER_SITE)))
    state, ts = act(step, state, F.Train_Marine_quick("now"))
    assert result(ts) == 0
    state, _ = wait(step, state, 400 // 8 - 1)
    marines = slots(state, UnitType.MARINE)
    assert len(marines) == 2
    np.testing.assert_array_equal(np.asarray(state.units.health)[marines], [45.0, 55.0])


def test_a_research_is_queued_once_cancelled_for_its_cost_and_scored():
    r = Research.INFANTRY_WEAPONS_1
    state, step, site = _at_structure(r)
    before = int(score.blizzard_score(state))
    state, _ = act(step, state, F.select_point("select", pixel(state, site)))
    state, ts = act(step, state, F.Research_TerranInfantryWeapons_quick("now"))
    # The queued research keeps the Blizzard score: its cost moved from the bank.
    assert result(ts) == 0 and int(score.blizzard_score(state)) == before
    # A second time: not on the card (NotSupported), and refused by the queue itself.
    _, ts = act(step, state, F.Research_TerranInfantryWeapons_quick("now"))
    assert result(ts) == ActionResult.NotSupported
    bank = jnp.stack([state.minerals, state.vespene])
    _, _, code = production.enqueue(state.units, bank, research.item(r), state.researched)
    assert int(code) == ActionResult.Error
    _, _, code = production.enqueue(state.units, bank, research.item(r),
                                    with_research(state, r).researched)
    assert int(code) == ActionResult.Error
    # The armour queues behind it at the same Engineering Bay.
    state, ts = act(step, state, F.Research_TerranInfantryArmor_quick("now"))
    assert result(ts) == 0 and int(state.minerals) == 800
    state, ts = act(step, state, F.Cancel_Last_quick("now"))
    state, ts = act(step, state, F.Cancel_Last_quick("now"))
    assert result(ts) == 0 and (int(state.minerals), int(state.vespene)) == (1000, 500)
    assert F.Research_TerranInfantryWeapons_quick.id in available(ts)
    # Done, it counts its cost.
    assert int(score.blizzard_score(with_research(state, r))) == before + 200


def test_stim_costs_health_and_moves_its_unit_half_as_fast_again_for_11_seconds():
    state, step, _ = _at_structure(Research.STIMPACK)
    marine = slots(state, UnitType.MARINE)[0]
    state, ts = act(step, state, F.select_point("select", pixel(state, MARINE_SITE)))
    assert F.Effect_Stim_quick.id not in available(ts)  # Not researched.
    state = with_research(state, Research.STIMPACK)
    state, ts = act(step, state, F.no_op())
    assert F.Effect_Stim_quick.id in available(ts)
    state, ts = act(step, state, F.Effect_Stim_quick("now"))
    assert result(ts) == 0 and float(state.units.health[marine]) == 35.0
    assert float(state.units.stim[marine]) == research.STIM_LOOPS - 8

    def moved(state):  # The distance walked in a step of 8 loops towards the left.
        start = np.asarray(state.units.pos[marine])
        state, _ = act(step, state, F.Move_screen("now", pixel(state, start - [10.0, 0.0])))
        return float(np.linalg.norm(np.asarray(state.units.pos[marine]) - start))

    speed = float(UNIT_DATA.speed[UnitType.MARINE])
    np.testing.assert_allclose(moved(state), 8 * speed * 1.5, rtol=1e-5)
    # 246 loops: the stim's last loop is in step 31 after the one that stimmed.
    late, _ = wait(step, state, 29)
    assert float(late.units.stim[marine]) == research.STIM_LOOPS - 30 * 8
    late, _ = wait(step, late, 1)
    assert float(late.units.stim[marine]) == 0.0
    np.testing.assert_allclose(moved(late), 8 * speed, rtol=1e-5)
    # A Marine with no more health than a stim costs cannot stim.
    weak = late.replace(units=late.units.replace(health=late.units.health.at[marine].set(10.0)))
    weak, ts = act(step, weak, F.Effect_Stim_quick("now"))
    assert result(ts) == ActionResult.Error and float(weak.units.health[marine]) == 10.0


PLAYABLE = (22.0, 20.0, 44.0, 36.0)
_LOOP = jax.jit(functools.partial(game_loop, playable=PLAYABLE))
M, Z, R, MARAUDER = UnitType.MARINE, UnitType.ZERGLING, UnitType.ROACH, UnitType.MARAUDER


def fight(units, *done, loops=1):
    researched = np.zeros(len(Research), bool)
    researched[list(done)] = True
    key = jax.random.PRNGKey(0)
    for _ in range(loops):
        key, k = jax.random.split(key)
        units, _ = _LOOP(units, k, researched=researched)
    return units


def _holding(spec):
    return units_of(spec, [(slot, Order.HOLD, None, xy) for slot, _, _, xy in spec])


@pytest.mark.parametrize("done", [(), (Research.INFANTRY_WEAPONS_1,),
                                  (Research.INFANTRY_ARMOR_1,)], ids=["none", "weapons", "armor"])
def test_infantry_weapons_and_armor_level_1_change_each_hit(done):
    # A Marine 4.5 from a Roach (gap 3.625: in range of both) and a Marauder 4.5 from
    # another. One loop, each fires once: the Marine 6 (+1) - 1 armour; the Marauder two
    # hits of 5 + 5 Armored (+0.5 + 0.5 each) - 1; each Roach 16 - (1 with the armour).
    units = _holding([(0, M, Owner.SELF, (26.0, 24.0)), (1, R, Owner.ENEMY, (30.5, 24.0)),
                      (2, MARAUDER, Owner.SELF, (26.0, 32.0)),
                      (3, R, Owner.ENEMY, (30.5, 32.0))])
    after = fight(units, *done)
    weapons, armor = Research.INFANTRY_WEAPONS_1 in done, Research.INFANTRY_ARMOR_1 in done
    assert float(after.health[1]) == 145.0 - (6.0 + weapons - 1.0)
    assert float(after.health[3]) == 145.0 - 2 * (10.0 + weapons - 1.0)
    assert float(after.health[0]) == 45.0 - (16.0 - armor)
    assert float(after.health[2]) == 125.0 - (16.0 - 1.0 - armor)


def test_concussive_shells_halve_the_speed_of_what_a_marauder_hits():
    # A Marauder holding 5 from a Zergling that walks away: hit on the first loop, the
    # Zergling is slowed for 24 loops, the slow renewed by every hit.
    spec = [(0, MARAUDER, Owner.SELF, (26.0, 28.0)), (1, Z, Owner.ENEMY, (31.0, 28.0))]
    units = units_of(spec, [(0, Order.HOLD, None, (26.0, 28.0)),
                            (1, Order.MOVE, None, (43.0, 28.0))])
    speed = float(UNIT_DATA.speed[Z])
    plain = fight(units, loops=1)
    assert float(plain.slow[1]) == 0.0
    np.testing.assert_allclose(float(plain.pos[1, 0]) - 31.0, speed, rtol=1e-5)
    slowed = fight(units, Research.CONCUSSIVE_SHELLS, loops=1)
    assert float(slowed.slow[1]) == research.SLOW_LOOPS
    after = fight(slowed, Research.CONCUSSIVE_SHELLS, loops=1)
    x = float(after.pos[1, 0]) - float(slowed.pos[1, 0])
    np.testing.assert_allclose(x, speed * research.SLOW_FACTOR, rtol=1e-5)
    assert float(after.slow[1]) == research.SLOW_LOOPS - 1
