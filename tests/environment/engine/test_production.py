"""Exact production scenes on CollectMineralsAndGas and BuildMarines: training, supply,
construction and placement, gas, rallies, cancels, the restricted command cards, and the
score (`production`, `score`); and each Terran unit and structure trained or built for
the Terran data table's cost, build time, producer and requirement, on
CollectMineralsAndGas's ground with its producers placed complete.

At screen resolution 32 the camera (32.94, 25.00) shows 0.75 world units per pixel.
Command Center (29.83, 28.01); SCV 50 minerals, 272 loops; Supply Depot 100, 480 loops;
Refinery 75, 480 loops.
"""

import functools
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS, Simulator, to_dense
from sc2jax.environment.engine import terran_data
from sc2jax.environment.engine.minigames.economy import COMMAND_CENTER, GEYSERS, LEFT_FIELDS
from sc2jax.environment.engine.observation import api_units
from sc2jax.environment.engine.rules import production, score
from sc2jax.environment.engine.rules.dynamics import game_loop
from sc2jax.environment.engine.rules.state import Order, Owner, first_slots, place
from sc2jax.environment.engine.rules.units import UnitType, game_name, terran_types
from sc2jax.environment.interface.observation_tables import Player, ScoreCumulative
from sc2jax.environment.interface.protocol_enums import ActionResult
from tests.environment.helpers import PARAMS, SMALL, assert_trees_equal, compiled, small_sim

CMAG, BM = "CollectMineralsAndGas", "BuildMarines"
F = FUNCTIONS


@functools.cache
def _start(map_name, minerals):
    reset, _ = compiled(small_sim(map_name))
    state = reset(jax.random.PRNGKey(0), PARAMS)[0]
    return state.replace(minerals=jnp.int32(minerals))


def start(map_name=CMAG, minerals=1000):
    """The map's first state with the given minerals, and its compiled step."""
    return _start(map_name, minerals), compiled(small_sim(map_name))[1]


def pixel(state, world):
    """The screen pixel (res 32) holding a world point."""
    cx, cy = np.asarray(state.camera)
    return [int(np.floor((world[0] - cx) / 0.75 + 16)), int(np.floor(16 - (world[1] - cy) / 0.75))]


def act(step, state, call, map_name=CMAG):
    state, ts = step(state, to_dense(call, small_sim(map_name).fmt.types), PARAMS)
    return state, jax.device_get(ts)


def wait(step, state, steps, map_name=CMAG):
    ts = None
    for _ in range(steps):
        state, ts = act(step, state, F.no_op(), map_name)
    return state, ts


def slots(state, unit_type):
    units = jax.device_get(state.units)
    return np.nonzero(units.alive & (units.type == unit_type))[0]


def result(ts):
    return int(ts.observation["action_result"][0])


def available(ts):
    return set(np.nonzero(ts.observation["available_actions_mask"])[0].tolist())


def select_cc(step, state):
    return act(step, state, F.select_point("select", pixel(state, COMMAND_CENTER)))


def select_scv(step, state, map_name=CMAG):
    scv = slots(state, UnitType.SCV)[0]
    return act(step, state, F.select_point("select", pixel(state, state.units.pos[scv])),
               map_name)


@pytest.mark.slow  # 11 s; the fast tier keeps the queue and payment errors below.
def test_train_scv_pays_queues_and_appears_after_its_build_time():
    state, step = start()
    state, ts = select_cc(step, state)
    assert {F.Train_SCV_quick.id, F.Rally_Workers_screen.id} <= available(ts)
    assert F.build_queue.id not in available(ts)  # No production panel yet.
    state, ts = act(step, state, F.Train_SCV_quick("now"))
    state, ts = act(step, state, F.Train_SCV_quick("now"))
    assert result(ts) == 0 and int(state.minerals) == 900
    # The first trains (its food counts), the second waits.
    assert ts.observation["player"][Player.food_used] == 13
    queue = ts.observation["production_queue"]
    assert queue[0, 0] == queue[1, 0] == F.Train_SCV_quick.ability_id
    assert 0 < queue[0, 1] < 100 and queue[1, 1] == 0 and queue[2, 0] == 0
    assert ts.observation["build_queue"][0, 0] == 45
    assert F.build_queue.id in available(ts)  # The production panel shows.
    # Queued on the step before last: 8 + 8 loops done; 272 needs 32 more steps.
    state, _ = wait(step, state, 31)
    assert len(slots(state, UnitType.SCV)) == 12
    state, ts = wait(step, state, 1)
    scvs = slots(state, UnitType.SCV)
    assert len(scvs) == 13
    new = scvs[np.argmax(np.asarray(state.units.tag)[scvs])]
    # Beside the Command Center, below it (no rally), and idle.
    cc = np.asarray(COMMAND_CENTER)
    assert np.linalg.norm(np.asarray(state.units.pos[new]) - cc) < 2.75 + 0.375 + 0.5
    assert int(state.units.orders[new, 0]) == Order.NONE
    assert ts.observation["player"][Player.food_workers] == 13


def test_train_errors_queue_full_minerals_and_supply():
    state, step = start()
    state, _ = select_cc(step, state)
    for _ in range(5):
        state, ts = act(step, state, F.Train_SCV_quick("now"))
        assert result(ts) == 0
    state, ts = act(step, state, F.Train_SCV_quick("now"))
    assert result(ts) == ActionResult.QueueIsFull and int(state.minerals) == 750
    state, ts = act(step, state, F.Cancel_Last_quick("now"))
    assert result(ts) == 0 and int(state.minerals) == 800
    poor = state.replace(minerals=jnp.int32(49))
    _, ts = act(step, poor, F.Train_SCV_quick("now"))
    assert result(ts) == ActionResult.NotEnoughMinerals
    # 15 of 15 food: two more SCVs alive and one training.
    state = _with_units(start()[0], [(UnitType.SCV, (36.0, 33.0)), (UnitType.SCV, (37.0, 33.0))])
    state, _ = select_cc(step, state)
    state, ts = act(step, state, F.Train_SCV_quick("now"))
    assert result(ts) == 0
    state, ts = act(step, state, F.Train_SCV_quick("now"))
    assert result(ts) == ActionResult.NotEnoughFood


def _with_units(state, specs, complete=True):
    """The state with more of the player's units in free slots."""
    units, tag = state.units, state.next_tag
    for unit_type, xy in specs:
        free = int(np.nonzero(~np.asarray(units.alive))[0][0])
        units, tag = place(units, jnp.array([free]), unit_type, Owner.SELF,
                           jnp.asarray([xy], jnp.float32), tag)
        if not complete:
            units = units.replace(progress=units.progress.at[free].set(0.0))
    return state.replace(units=units, next_tag=tag)


def test_supply_depot_is_placed_on_arrival_and_built_in_480_loops():
    state, step = start()
    state, _ = select_scv(step, state)
    site = (33.0, 33.0)
    state, ts = act(step, state, F.Build_SupplyDepot_screen("now", pixel(state, site)))
    assert result(ts) == 0 and int(state.minerals) == 1000  # Paid on arrival.
    builder = slots(state, UnitType.SCV)[0]
    assert int(state.units.orders[builder, 0]) == Order.BUILD
    for _ in range(30):
        state, ts = wait(step, state, 1)
        if len(slots(state, UnitType.SUPPLY_DEPOT)):
            break
    depot = slots(state, UnitType.SUPPLY_DEPOT)[0]
    np.testing.assert_allclose(np.asarray(state.units.pos[depot]), site)
    assert int(state.minerals) == 900
    assert int(state.units.orders[builder, 0]) == Order.CONSTRUCT
    assert 40 <= float(state.units.health[depot]) < 60
    assert ts.observation["player"][Player.food_cap] == 15
    assert ts.observation["score_cumulative"][ScoreCumulative.spent_minerals] == 100
    progress = float(state.units.progress[depot])
    state, ts = wait(step, state, int(np.ceil((480 - progress) / 8)))
    assert float(state.units.health[depot]) == 400
    assert ts.observation["player"][Player.food_cap] == 23
    assert int(state.units.orders[builder, 0]) == Order.NONE


def test_placement_errors():
    state, step = start()
    state, _ = select_scv(step, state)
    depot, cc, refinery = (F.Build_SupplyDepot_screen, F.Build_CommandCenter_screen,
                           F.Build_Refinery_screen)
    cases = [(depot, tuple(LEFT_FIELDS[0]), ActionResult.CantFindPlacementLocation),
             (depot, (33.0, 36.9), ActionResult.CantBuildLocationInvalid),
             (depot, (29.8, 28.0), ActionResult.CantFindPlacementLocation),
             (cc, (31.5, 33.5), ActionResult.CantBuildTooCloseToResources),
             (refinery, (33.0, 33.0), ActionResult.CantTargetThatUnit)]
    for function, site, error in cases:
        _, ts = act(step, state, function("now", pixel(state, site)))
        assert result(ts) == error, (function.name, site)
    _, ts = act(step, state.replace(minerals=jnp.int32(99)),
                F.Build_SupplyDepot_screen("now", pixel(state, (33.0, 33.0))))
    assert result(ts) == ActionResult.NotEnoughMinerals


def test_barracks_needs_a_complete_supply_depot():
    state, step = start()
    _, ts = select_scv(step, state)
    assert F.Build_Barracks_screen.id not in available(ts)
    unfinished = _with_units(state, [(UnitType.SUPPLY_DEPOT, (36.0, 34.0))], complete=False)
    _, ts = select_scv(step, unfinished)
    assert F.Build_Barracks_screen.id not in available(ts)
    done = _with_units(state, [(UnitType.SUPPLY_DEPOT, (36.0, 34.0))])
    _, ts = select_scv(step, done)
    assert F.Build_Barracks_screen.id in available(ts)
    assert ts.observation["player"][Player.food_cap] == 23


def test_refinery_replaces_its_geyser_and_workers_bring_4_gas():
    state, step = start()
    state, _ = select_scv(step, state)
    geyser = tuple(GEYSERS[3])  # (26.5, 20.5), below the left mineral line.
    state, ts = act(step, state, F.Build_Refinery_screen("now", pixel(state, geyser)))
    assert result(ts) == 0
    for _ in range(60):
        state, ts = wait(step, state, 1)
        if len(slots(state, UnitType.REFINERY)):
            break
    refinery = slots(state, UnitType.REFINERY)[0]
    assert len(slots(state, UnitType.VESPENE_GEYSER)) == 3
    assert float(state.units.contents[refinery]) == 2250 and int(state.minerals) == 925
    # Unfinished: its card is Cancel only.
    state, ts = act(step, state, F.select_point("select", pixel(state, geyser)))
    assert F.Cancel_quick.id in available(ts) and F.Smart_screen.id not in available(ts)
    state, _ = wait(step, state, 60)
    assert bool(state.units.complete[refinery])
    state, _ = select_scv(step, state)
    state, _ = act(step, state, F.Smart_screen("now", pixel(state, geyser)))
    gas = []
    for _ in range(30):
        state, ts = wait(step, state, 1)
        gas.append(int(ts.observation["score_cumulative"][ScoreCumulative.collected_vespene]))
    assert gas[-1] >= 4 and gas[-1] % 4 == 0 and int(state.vespene) == gas[-1]
    # The map's score is the minerals and vespene collected.
    collected = ts.observation["score_cumulative"]
    assert collected[0] == (collected[ScoreCumulative.collected_minerals]
                            + collected[ScoreCumulative.collected_vespene])


def test_rally_to_a_mineral_field_sends_new_scvs_to_gather():
    state, step = start()
    state, _ = select_cc(step, state)
    field = tuple(LEFT_FIELDS[0])
    state, ts = act(step, state, F.Rally_Workers_screen("now", pixel(state, field)))
    assert result(ts) == 0
    state, _ = act(step, state, F.Train_SCV_quick("now"))
    state, _ = wait(step, state, 34)
    scvs = slots(state, UnitType.SCV)
    new = scvs[np.argmax(np.asarray(state.units.tag)[scvs])]
    assert int(state.units.orders[new, 0]) in (Order.GATHER, Order.RETURN)


def test_cancel_construction_refunds_three_quarters():
    state, step = start()
    state = _with_units(state, [(UnitType.SUPPLY_DEPOT, (36.0, 34.0))], complete=False)
    state, ts = act(step, state, F.select_point("select", pixel(state, (36.0, 34.0))))
    assert available(ts) & {F.Cancel_quick.id} and F.Cancel_Last_quick.id not in available(ts)
    state, ts = act(step, state, F.Cancel_quick("now"))
    assert result(ts) == 0 and int(state.minerals) == 1075
    assert len(slots(state, UnitType.SUPPLY_DEPOT)) == 0


def test_select_idle_worker_one_and_all():
    state, step = start()
    _, ts = act(step, state, F.select_idle_worker("select"))
    assert ts.observation["single_select"][0, 0] == 45
    _, ts = act(step, state, F.select_idle_worker("select_all"))
    assert (ts.observation["multi_select"][:, 0] == 45).sum() == 12


@pytest.mark.slow  # About 15-20 s on 2 cores: the fast tier stays under 3 minutes.
def test_build_marines_command_cards():
    state, step = start(BM)
    ui = {F.no_op.id, F.move_camera.id, F.select_point.id, F.select_rect.id,
          F.select_control_group.id}
    _, ts = select_scv(step, state, BM)
    assert available(ts) == ui | {F.Smart_screen.id, F.Smart_minimap.id,
                                  F.Harvest_Gather_screen.id, F.Build_SupplyDepot_screen.id}
    _, ts = act(step, state, F.select_point("select", pixel(state, COMMAND_CENTER)), BM)
    assert available(ts) == ui | {F.Train_SCV_quick.id, F.Rally_Workers_screen.id,
                                  F.Rally_Workers_minimap.id, F.Smart_screen.id,
                                  F.Smart_minimap.id}


@pytest.mark.slow  # BuildMarines' step compiles in 15-25 s: the fast tier stays under 3 minutes.
def test_build_marines_scores_each_marine_created():
    state, step = start(BM)
    state = _with_units(state, [(UnitType.SUPPLY_DEPOT, (36.0, 34.0)),
                                (UnitType.BARRACKS, (36.5, 28.5))])
    barracks = slots(state, UnitType.BARRACKS)[0]
    state, ts = act(step, state, F.select_point("select", pixel(state, (36.5, 28.5))), BM)
    assert available(ts) - {0, 1, 2, 3, 4} == {F.Train_Marine_quick.id, F.Smart_screen.id,
                                                F.Smart_minimap.id}
    state, _ = act(step, state, F.Train_Marine_quick("now"), BM)
    state, _ = act(step, state, F.Train_Marine_quick("now"), BM)
    assert int(state.units.queue[barracks, 1]) == UnitType.MARINE
    rewards = []
    for _ in range(110):
        state, ts = act(step, state, F.no_op(), BM)
        rewards.append(float(ts.reward))
    assert sum(rewards) == 2 and len(slots(state, UnitType.MARINE)) == 2
    # The first after 400 loops (50 steps, queued in the step before last), then 400 more.
    assert np.nonzero(rewards)[0].tolist() == [47, 97]


@pytest.mark.slow  # BuildMarines' step compiles in 15-25 s: the fast tier stays under 3 minutes.
def test_workers_spread_over_the_mineral_line():
    state, step = start(BM, minerals=50)
    state, _ = wait(step, state, 40, BM)
    units = jax.device_get(state.units)
    gathering = units.alive & (units.type == UnitType.SCV)
    fields = set(units.home[gathering].tolist())
    assert len(fields) >= 6


def test_blizzard_score_reward_ignores_spending_and_counts_income():
    state, step = start()
    state, _ = select_cc(step, state)
    trained, _ = act(step, state, F.Train_SCV_quick("now"))
    assert int(trained.minerals) == int(state.minerals) - 50
    # The reward of score_index=-2 (computed here without compiling that simulator).
    blizzard = Simulator(CMAG, fmt=SMALL, score_index=-2)
    before, after = score.blizzard_score(state), score.blizzard_score(trained)
    assert int(before) == 1000 + 12 * 50 + 400  # Minerals, SCVs, the Command Center.
    assert float(blizzard._reward(state, trained, False)) == float(after - before) == 0.0
    richer = trained.replace(minerals=trained.minerals + 5)
    assert float(blizzard._reward(trained, richer, False)) == 5.0


def test_bad_score_index_names_what_is_allowed():
    for bad in (-3, 13, 1.0):
        with pytest.raises(ValueError, match=r"score_index must be -2 \(the Blizzard score\)"):
            Simulator(CMAG, fmt=SMALL, score_index=bad)


@pytest.mark.slow  # Two BuildMarines programs, about 30 s: the fast tier stays under 3 minutes.
@pytest.mark.parametrize("marines, needs", [(10, [32, 33, 33]), (11, [33, 34, 34])])
def test_leading_slots_play_the_same_game_as_all_slots(marines, needs):
    """BuildMarines runs its game loops on the leading slots in use and one more per
    unit that can create one (`slot_sizes` (32, 96, 200)), and observes the slots in
    use. A start with marines in slots 21 on, whose Command Center finishes an SCV in
    the first step, plays and is observed bit for bit as by the engine on all 200 slots
    (`use_slot_sizes=False`): with 10 marines at 32 slots, then at 96; with 11 at 96,
    which the Command Center's room decides (at 32 the SCV would find no free slot).
    Batches take their largest need: tests/environment/test_lazy.py."""
    state, step_every = start(BM)  # `small_sim`: every slot.
    step = compiled(small_sim(BM, sized=True))[1]
    units, tag = place(state.units, 21 + np.arange(marines), UnitType.MARINE, Owner.SELF,
                       jnp.asarray(COMMAND_CENTER) + jnp.stack(
                           [jnp.linspace(-4.0, 4.0, marines), jnp.full(marines, -4.0)],
                           axis=1), state.next_tag)
    cc = slots(state, UnitType.COMMAND_CENTER)[0]
    units = units.replace(queue=units.queue.at[cc, 0].set(UnitType.SCV),
                          queue_work=units.queue_work.at[cc, 0].set(270.0))
    need = jax.jit(small_sim(BM, sized=True).slots_needed)
    a = b = state.replace(units=units, next_tag=tag)
    seen = []
    for _ in range(3):
        seen.append(int(need(a.units)))
        (a, ts_a), (b, ts_b) = act(step, a, F.no_op(), BM), act(step_every, b, F.no_op(), BM)
        assert_trees_equal((a, ts_a), (b, ts_b))
    assert seen == needs
    assert int(a.units.alive.sum()) == 22 + marines  # The new SCV.


def test_bad_use_slot_sizes_names_what_is_allowed():
    for bad in (0, "yes", None):
        with pytest.raises(ValueError, match=r"use_slot_sizes must be a bool, got"):
            Simulator(BM, fmt=SMALL, use_slot_sizes=bad)


def test_first_slots_is_nonzero_and_the_economy_loop_has_no_scatter():
    rng = np.random.default_rng(0)
    for count in (1, 4, 12):
        for mask in (rng.random(12) < 0.3, np.zeros(12, bool), np.ones(12, bool)):
            np.testing.assert_array_equal(
                first_slots(mask, count), jnp.nonzero(mask, size=count, fill_value=12)[0])
    # Harvest and production by pairs and selects: XLA's CPU backend can compile the
    # game loop whole (`devices.compile_small_loops_whole`).
    sim = small_sim("CollectMineralsAndGas")
    game = sim.game
    state, _ = compiled(sim)[0](jax.random.PRNGKey(0), PARAMS)

    def loop(units, key):
        units, _ = game_loop(units, key, game.geometry.playable, workers=True, combat=False,
                             colliders=game.collider_slots, field_slots=game.field_slots,
                             sized=True)
        return production.production_loop(units, jnp.array([50, 0], jnp.int32), jnp.int32(1),
                                          jnp.asarray(game.geometry.buildable))

    hlo = jax.jit(loop).lower(state.units, state.key).compile().as_text()
    assert not re.search(r"= \S+ scatter", hlo)


# The Terran data table's units and structures.

PRODUCER_SITE = (37.5, 25.5)  # Clear of the SCVs, the Command Center and the fields.
DEPOTS = [(UnitType.SUPPLY_DEPOT, (36.0, 34.0)), (UnitType.SUPPLY_DEPOT, (38.0, 34.0))]
TRAINED = {UnitType.MARINE: UnitType.BARRACKS, UnitType.REAPER: UnitType.BARRACKS,
           UnitType.MARAUDER: UnitType.BARRACKS, UnitType.HELLION: UnitType.FACTORY,
           UnitType.SIEGE_TANK: UnitType.FACTORY, UnitType.MEDIVAC: UnitType.STARPORT,
           UnitType.VIKING_FIGHTER: UnitType.STARPORT}
ADDONS = {UnitType.BARRACKS: (UnitType.BARRACKS_TECH_LAB, UnitType.BARRACKS_REACTOR),
          UnitType.FACTORY: (UnitType.FACTORY_TECH_LAB, UnitType.FACTORY_REACTOR),
          UnitType.STARPORT: (UnitType.STARPORT_TECH_LAB, UnitType.STARPORT_REACTOR)}
ADDON_SITE = (PRODUCER_SITE[0] + 2.5, PRODUCER_SITE[1] - 0.5)
BUILT = (UnitType.SUPPLY_DEPOT, UnitType.BARRACKS, UnitType.FACTORY, UnitType.STARPORT,
         UnitType.ENGINEERING_BAY, UnitType.BUNKER, UnitType.COMMAND_CENTER)


def row(unit_type):
    return terran_data.unit(game_name(unit_type))


def test_the_producers_are_the_tables():
    for unit, producer in TRAINED.items():
        assert game_name(producer) in row(unit)["producers"]
        assert production.MAKES[producer, unit]
    for structure in BUILT:
        assert row(structure)["producers"] == ["SCV"]
        assert production.MAKES[UnitType.SCV, structure]
    assert UnitType(int(production.BUILDS[0])) in BUILT


@pytest.mark.parametrize("unit", list(TRAINED), ids=lambda t: t.name)
def test_each_unit_costs_and_trains_for_its_table_values(unit):
    data = row(unit)
    state, step = start()
    state = _with_units(state, [(TRAINED[unit], PRODUCER_SITE)] + DEPOTS)
    if data["requires_addon"]:  # The Marauder and the Siege Tank: a Tech Lab.
        assert data["requires_addon"] == "TechLab"
        state = _with_addon(state, ADDONS[TRAINED[unit]][0])
    state = state.replace(minerals=jnp.int32(1000), vespene=jnp.int32(500))
    state, ts = act(step, state, F.select_point("select", pixel(state, PRODUCER_SITE)))
    train = F[f"Train_{game_name(unit)}_quick"]
    assert train.id in available(ts)
    before = len(slots(state, unit))
    state, ts = act(step, state, train("now"))
    assert result(ts) == 0
    assert (int(state.minerals), int(state.vespene)) == (1000 - data["minerals"],
                                                         500 - data["vespene"])
    spent = ts.observation["score_cumulative"]
    assert (spent[ScoreCumulative.spent_minerals], spent[ScoreCumulative.spent_vespene]) == (
        data["minerals"], data["vespene"])
    # Queued at the start of a step of 8 loops, whose loops train it: it appears in the
    # step where its build time is reached, and not before.
    loops = int(data["build_time"])
    assert loops % 8 == 0
    state, _ = wait(step, state, loops // 8 - 2)
    assert len(slots(state, unit)) == before
    state, _ = wait(step, state, 1)
    assert len(slots(state, unit)) == before + 1


def _with_addon(state, addon, complete=True):
    """The state with `addon` attached, complete or just started, to the producer at
    PRODUCER_SITE."""
    units = jax.device_get(state.units)
    (producer,) = np.flatnonzero(units.alive & np.isclose(units.pos, PRODUCER_SITE).all(1))
    (slot,) = np.flatnonzero(~units.alive)[:1]  # Where `_with_units` puts it.
    state = _with_units(state, [(addon, ADDON_SITE)], complete)
    units = state.units
    return state.replace(units=units.replace(addon=units.addon.at[producer].set(int(slot))))


def _select_producer(step, state):
    return act(step, state, F.select_point("select", pixel(state, PRODUCER_SITE)))


@pytest.mark.parametrize("addon", [a for pair in ADDONS.values() for a in pair],
                         ids=lambda t: t.name)
def test_each_addon_is_built_beside_its_producer_for_its_table_values(addon):
    data = row(addon)
    (producer,) = [p for p, pair in ADDONS.items() if addon in pair]
    assert data["producers"] == [game_name(producer)] and data["footprint"] == [2, 2]
    state, step = start()
    state = _with_units(state, [(producer, PRODUCER_SITE)] + DEPOTS)
    state = state.replace(minerals=jnp.int32(1000), vespene=jnp.int32(500))
    state, ts = _select_producer(step, state)
    build = F.Build_TechLab_quick if addon == ADDONS[producer][0] else F.Build_Reactor_quick
    assert {F.Build_TechLab_quick.id, F.Build_Reactor_quick.id} <= available(ts)
    state, ts = act(step, state, build("now"))
    assert result(ts) == 0
    assert (int(state.minerals), int(state.vespene)) == (1000 - data["minerals"],
                                                         500 - data["vespene"])
    (placed,) = slots(state, addon)
    np.testing.assert_allclose(np.asarray(state.units.pos[placed]), ADDON_SITE)
    assert int(state.units.addon[slots(state, producer)[0]]) == placed
    # Built from the action's game loop on, one loop per loop, from a tenth of its
    # health to full; the producer offers no other add-on meanwhile.
    assert float(state.units.progress[placed]) == 8.0
    np.testing.assert_allclose(float(state.units.health[placed]),
                               data["health"] * (0.1 + 0.9 * 8 / data["build_time"]), rtol=1e-5)
    assert not {F.Build_TechLab_quick.id, F.Build_Reactor_quick.id} & available(ts)
    # The API shows the add-on's ability as the producer's order, with its progress.
    api = jax.device_get(api_units(state, small_sim(CMAG).renderer))
    builder = slots(state, producer)[0]
    assert api["order_abilities"][builder, 0] == data["ability_id"]
    np.testing.assert_allclose(api["order_progress_0"][builder], 8 / data["build_time"])
    state, _ = wait(step, state, int(data["build_time"]) // 8 - 2)
    assert not bool(state.units.complete[placed])
    state, _ = wait(step, state, 1)
    assert bool(state.units.complete[placed])
    np.testing.assert_allclose(float(state.units.health[placed]), data["health"], rtol=1e-5)


def test_a_producer_trains_nothing_while_its_addon_is_built():
    state, step = start()
    state = _with_units(state, [(UnitType.BARRACKS, PRODUCER_SITE)] + DEPOTS)
    state = _with_addon(state, UnitType.BARRACKS_TECH_LAB, complete=False)
    state, ts = _select_producer(step, state)
    assert F.Train_Marauder_quick.id not in available(ts)  # Its Tech Lab is unfinished.
    state, ts = act(step, state, F.Train_Marine_quick("now"))
    assert result(ts) == 0
    barracks = slots(state, UnitType.BARRACKS)[0]
    state, _ = wait(step, state, 400 // 8 - 3)
    assert float(state.units.queue_work[barracks, 0]) == 0.0
    # The Tech Lab (placed unfinished before the 2 steps above) completes in the last
    # loop of the next step, in which the Marine starts training.
    state, ts = wait(step, state, 2)
    assert float(state.units.queue_work[barracks, 0]) == 9.0
    assert F.Train_Marauder_quick.id in available(ts)


def test_addon_errors_busy_blocked_poor_and_none_to_build():
    state, step = start()
    base = _with_units(state, [(UnitType.BARRACKS, PRODUCER_SITE)] + DEPOTS)
    base = base.replace(minerals=jnp.int32(1000), vespene=jnp.int32(500))
    busy, _ = _select_producer(step, base)
    busy, _ = act(step, busy, F.Train_Marine_quick("now"))
    _, ts = act(step, busy, F.Build_TechLab_quick("now"))
    assert result(ts) == ActionResult.CantQueueThatOrder
    blocked, _ = _select_producer(step, _with_units(base, [(UnitType.SUPPLY_DEPOT,
                                                           (ADDON_SITE[0] + 1, ADDON_SITE[1]))]))
    _, ts = act(step, blocked, F.Build_Reactor_quick("now"))
    assert result(ts) == ActionResult.CantFindPlacementLocation
    poor, _ = _select_producer(step, base.replace(vespene=jnp.int32(49)))
    poor, ts = act(step, poor, F.Build_Reactor_quick("now"))
    assert result(ts) == ActionResult.NotEnoughVespene
    assert (int(poor.minerals), int(poor.vespene)) == (1000, 49)
    assert not len(slots(poor, UnitType.BARRACKS_REACTOR))
    _, ts = select_cc(step, base)  # A Command Center builds no add-on.
    assert F.Build_TechLab_quick.id not in available(ts)


def test_every_selected_producer_builds_an_addon_while_the_bank_lasts():
    second = (PRODUCER_SITE[0], PRODUCER_SITE[1] + 4)
    state, step = start()
    state = _with_units(state, [(UnitType.BARRACKS, PRODUCER_SITE), (UnitType.BARRACKS, second)]
                        + DEPOTS)
    rect = F.select_rect("select", pixel(state, (second[0] - 2, second[1] + 2)),
                         pixel(state, (PRODUCER_SITE[0] + 2, PRODUCER_SITE[1] - 2)))
    for vespene, built in ((100, 2), (99, 1)):
        selected, _ = act(step, state.replace(vespene=jnp.int32(vespene)), rect)
        selected, ts = act(step, selected, F.Build_Reactor_quick("now"))
        assert result(ts) == 0 and len(slots(selected, UnitType.BARRACKS_REACTOR)) == built
        assert int(selected.vespene) == vespene - 50 * built


def test_a_reactor_trains_two_at_once_from_a_queue_of_8():
    state, step = start()
    state = _with_units(state, [(UnitType.BARRACKS, PRODUCER_SITE)] + DEPOTS)
    state = _with_addon(state, UnitType.BARRACKS_REACTOR)
    state = state.replace(minerals=jnp.int32(1000))
    state, ts = _select_producer(step, state)
    assert F.Train_Marauder_quick.id not in available(ts)  # A Reactor is no Tech Lab.
    for _ in range(8):
        state, ts = act(step, state, F.Train_Marine_quick("now"))
        assert result(ts) == 0
    state, ts = act(step, state, F.Train_Marine_quick("now"))
    assert result(ts) == ActionResult.QueueIsFull
    # Two in training since their steps: 9 steps (72 loops) and 8 (64 loops) of 400.
    shown = ts.observation["production_queue"]
    assert len(shown) == 8 and (shown[:, 0] == F.Train_Marine_quick.ability_id).all()
    assert shown[:, 1].tolist() == [18, 16, 0, 0, 0, 0, 0, 0]
    # The first appears in the step that reaches its 400 loops, the second a step later;
    # the third starts as the first leaves.
    state, _ = wait(step, state, 400 // 8 - 10)
    assert len(slots(state, UnitType.MARINE)) == 0
    state, _ = wait(step, state, 1)
    assert len(slots(state, UnitType.MARINE)) == 1
    state, _ = wait(step, state, 1)
    assert len(slots(state, UnitType.MARINE)) == 2
    barracks = slots(state, UnitType.BARRACKS)[0]
    assert int(np.sum(np.asarray(state.units.queue[barracks]) != 0)) == 6
    assert np.asarray(state.units.queue_work[barracks]).tolist() == [8.0] + [0.0] * 7


def test_too_little_vespene_is_not_enough_vespene():
    state, step = start()
    state = _with_units(state, [(UnitType.STARPORT, PRODUCER_SITE)] + DEPOTS)
    state = state.replace(minerals=jnp.int32(1000), vespene=jnp.int32(99))
    state, _ = act(step, state, F.select_point("select", pixel(state, PRODUCER_SITE)))
    state, ts = act(step, state, F.Train_Medivac_quick("now"))
    assert result(ts) == ActionResult.NotEnoughVespene
    assert (int(state.minerals), int(state.vespene)) == (1000, 99)


@pytest.mark.parametrize("structure", [UnitType.FACTORY, UnitType.STARPORT,
                                       UnitType.ENGINEERING_BAY, UnitType.BUNKER],
                         ids=lambda t: t.name)
def test_each_structure_needs_its_table_requirement(structure):
    needed = terran_types()[row(structure)["requires"]]
    build = F[f"Build_{game_name(structure)}_screen"]
    state, step = start()
    if needed == UnitType.COMMAND_CENTER:  # The map's Command Center: gone, then back.
        cc = slots(state, UnitType.COMMAND_CENTER)[0]
        units = state.units
        state = state.replace(units=units.replace(alive=units.alive.at[cc].set(False)))
        _, ts = select_scv(step, state)
        assert build.id not in available(ts)
        return
    _, ts = select_scv(step, state)
    assert build.id not in available(ts)
    unfinished = _with_units(state, [(needed, PRODUCER_SITE)], complete=False)
    _, ts = select_scv(step, unfinished)
    assert build.id not in available(ts)
    _, ts = select_scv(step, _with_units(state, [(needed, PRODUCER_SITE)]))
    assert build.id in available(ts)


def test_a_lowered_depot_and_an_orbital_command_count_for_requirements():
    state, step = start()
    _, ts = select_scv(step, _with_units(state, [(UnitType.SUPPLY_DEPOT_LOWERED, (36.0, 34.0))]))
    assert F.Build_Barracks_screen.id in available(ts)
    cc = slots(state, UnitType.COMMAND_CENTER)[0]
    units = state.units
    orbital = state.replace(units=units.replace(type=units.type.at[cc].set(
        UnitType.ORBITAL_COMMAND)))
    _, ts = select_scv(step, orbital)
    assert F.Build_EngineeringBay_screen.id in available(ts)


@pytest.mark.parametrize("structure", [UnitType.FACTORY, UnitType.ENGINEERING_BAY,
                                       UnitType.BUNKER], ids=lambda t: t.name)
def test_each_structure_costs_and_builds_for_its_table_values(structure):
    data = row(structure)
    site = (34.5, 33.5)
    state, step = start()
    state = _with_units(state, [(UnitType.BARRACKS, PRODUCER_SITE)])
    state = state.replace(minerals=jnp.int32(1000), vespene=jnp.int32(500))
    state, _ = select_scv(step, state)
    build = F[f"Build_{game_name(structure)}_screen"]
    state, ts = act(step, state, build("now", pixel(state, site)))
    assert result(ts) == 0
    for _ in range(30):
        state, ts = wait(step, state, 1)
        if len(slots(state, structure)):
            break
    placed = slots(state, structure)[0]
    np.testing.assert_allclose(np.asarray(state.units.pos[placed]), site)
    assert (int(state.minerals), int(state.vespene)) == (1000 - data["minerals"],
                                                         500 - data["vespene"])
    # Constructed one loop per game loop, for its build time, to full health.
    remaining = data["build_time"] - float(state.units.progress[placed])
    state, _ = wait(step, state, int(np.ceil(remaining / 8)) - 1)
    assert not bool(state.units.complete[placed])
    state, _ = wait(step, state, 1)
    assert bool(state.units.complete[placed])
    assert float(state.units.health[placed]) == data["health"]
    builder = slots(state, UnitType.SCV)[0]
    assert int(state.units.orders[builder, 0]) == Order.NONE



def test_a_command_center_upgrades_to_an_orbital_command_alone_in_its_queue():
    data = row(UnitType.ORBITAL_COMMAND)
    assert data["morphs_from"] == "CommandCenter" and data["requires"] == "Barracks"
    state, step = start()
    _, ts = select_cc(step, state)
    assert F.Morph_OrbitalCommand_quick.id not in available(ts)  # No Barracks yet.
    state = _with_units(state, [(UnitType.BARRACKS, PRODUCER_SITE)])
    state, ts = select_cc(step, state)
    assert F.Morph_OrbitalCommand_quick.id in available(ts)
    worth = int(score.blizzard_score(state))
    state, ts = act(step, state, F.Morph_OrbitalCommand_quick("now"))
    price = data["minerals"] - row(UnitType.COMMAND_CENTER)["minerals"]
    assert result(ts) == 0 and price == 150 and int(state.minerals) == 1000 - price
    assert int(score.blizzard_score(state)) == worth  # Its price, from bank to queue.
    assert ts.observation["production_queue"][0, 0] == F.Morph_OrbitalCommand_quick.ability_id
    _, ts = act(step, state, F.Train_SCV_quick("now"))
    assert result(ts) == ActionResult.CantQueueThatOrder  # Busy upgrading.
    cancelled, _ = act(step, state, F.Cancel_Last_quick("now"))
    assert int(cancelled.minerals) == 1000
    cc = slots(state, UnitType.COMMAND_CENTER)[0]
    state, _ = wait(step, state, int(data["build_time"]) // 8 - 2)
    assert int(state.units.type[cc]) == UnitType.COMMAND_CENTER
    state, ts = wait(step, state, 1)
    assert int(state.units.type[cc]) == UnitType.ORBITAL_COMMAND
    assert not state.units.queue[cc].any()
    # Its starting 50 energy, then 0.5625 per game second (here the rest of the step).
    assert data["start_energy"] == 50
    assert float(state.units.energy[cc]) == pytest.approx(50 + 0.5625 / 16 * 1, abs=1e-4)
    state, ts = wait(step, state, 2)
    assert float(state.units.energy[cc]) == pytest.approx(50 + 0.5625 / 16 * 17, abs=1e-4)
    energy = ts.observation["feature_screen"][small_sim(CMAG).fmt.screen_index("unit_energy")]
    assert energy[tuple(pixel(state, COMMAND_CENTER)[::-1])] == 50  # The screen shows it.
    state, ts = act(step, state, F.Train_SCV_quick("now"))
    assert result(ts) == 0


@pytest.mark.parametrize("first, second, morph, back", [
    (UnitType.SUPPLY_DEPOT, UnitType.SUPPLY_DEPOT_LOWERED, "Morph_SupplyDepot_Lower_quick",
     "Morph_SupplyDepot_Raise_quick"),
    (UnitType.SIEGE_TANK, UnitType.SIEGE_TANK_SIEGED, "Morph_SiegeMode_quick",
     "Morph_Unsiege_quick"),
    (UnitType.VIKING_FIGHTER, UnitType.VIKING_ASSAULT, "Morph_VikingAssaultMode_quick",
     "Morph_VikingFighterMode_quick")], ids=lambda v: getattr(v, "name", None))
def test_a_mode_switches_at_once_and_holds_fire_for_its_morph_time(first, second, morph, back):
    loops = row(second)["build_time"]
    assert row(second)["morphs_from"] == game_name(first)
    state, step = start()
    state = _with_units(state, [(first, PRODUCER_SITE)] + DEPOTS[1:])
    cap = int(production.food_cap(state.units))
    (slot,) = [s for s in slots(state, first) if np.allclose(state.units.pos[s], PRODUCER_SITE)]
    state, ts = _select_producer(step, state)
    assert F[morph].id in available(ts) and F[back].id not in available(ts)
    state, ts = act(step, state, F[morph]("now"))
    assert result(ts) == 0 and int(state.units.type[slot]) == second
    assert bool(state.units.complete[slot])
    # The morph time less the step's 8 loops (the weapon's own cooldown where longer).
    assert float(state.units.cooldown[slot]) == pytest.approx(max(loops - 8, 0), abs=1e-3)
    assert int(production.food_cap(state.units)) == cap  # A lowered depot still supplies.
    state, ts = act(step, state, F.no_op())
    assert F[back].id in available(ts) and F[morph].id not in available(ts)
    state, ts = act(step, state, F[back]("now"))
    assert result(ts) == 0 and int(state.units.type[slot]) == first
    assert bool(state.units.complete[slot])


def test_a_barracks_lifts_off_flies_and_lands_taking_the_addon_beside_it():
    flying = row(UnitType.BARRACKS_FLYING)
    assert flying["morphs_from"] == "Barracks" and flying["flying"]
    state, step = start()
    state = _with_units(state, [(UnitType.BARRACKS, PRODUCER_SITE)] + DEPOTS)
    state = _with_addon(state, UnitType.BARRACKS_TECH_LAB)
    barracks = slots(state, UnitType.BARRACKS)[0]
    lab = int(state.units.addon[barracks])
    state, ts = _select_producer(step, state)
    assert F.Lift_quick.id in available(ts) and F.Train_Marauder_quick.id in available(ts)
    state, ts = act(step, state, F.Lift_quick("now"))
    assert result(ts) == 0 and int(state.units.type[barracks]) == UnitType.BARRACKS_FLYING
    # Flying: it moves at its speed, trains nothing, and leaves its Tech Lab behind.
    assert F.Land_screen.id in available(ts) and F.Train_Marine_quick.id not in available(ts)
    assert int(production.addon_kinds(state.units)[0][barracks]) == 0
    away = (PRODUCER_SITE[0], PRODUCER_SITE[1] + 4)
    state, _ = act(step, state, F.Move_screen("now", pixel(state, away)))
    speed = flying["speed"] / 16  # World units per game loop (Normal speed's second).
    travelled = np.linalg.norm(np.asarray(state.units.pos[barracks]) - PRODUCER_SITE)
    np.testing.assert_allclose(travelled, 8 * speed, atol=1e-4)
    # Landing on its Tech Lab's own footprint fails: the order ends, it hovers.
    state, ts = act(step, state, F.Land_screen("now", pixel(state, (ADDON_SITE[0] + 1,
                                                                     ADDON_SITE[1]))))
    assert result(ts) == ActionResult.CantFindPlacementLocation
    # Landed back by the Tech Lab, the Barracks has it again.
    state, ts = act(step, state, F.Land_screen("now", pixel(state, PRODUCER_SITE)))
    assert result(ts) == 0
    state, _ = wait(step, state, 6)
    assert int(state.units.type[barracks]) == UnitType.BARRACKS
    np.testing.assert_allclose(np.asarray(state.units.pos[barracks]), PRODUCER_SITE)
    assert int(state.units.addon[barracks]) == lab
    state, ts = _select_producer(step, state)
    assert F.Train_Marauder_quick.id in available(ts)


def test_a_factory_landing_by_a_barracks_tech_lab_takes_it_as_its_own():
    state, step = start()
    state = _with_units(state, [(UnitType.FACTORY_FLYING, PRODUCER_SITE)] + DEPOTS)
    state = _with_units(state, [(UnitType.BARRACKS_TECH_LAB, ADDON_SITE)])
    (lab,) = slots(state, UnitType.BARRACKS_TECH_LAB)
    state, ts = _select_producer(step, state)
    state, ts = act(step, state, F.Land_screen("now", pixel(state, PRODUCER_SITE)))
    assert result(ts) == 0
    (factory,) = slots(state, UnitType.FACTORY)
    assert int(state.units.type[lab]) == UnitType.FACTORY_TECH_LAB
    assert int(production.addon_kinds(state.units)[0][factory]) == production.AddOn.TECH_LAB


def test_a_command_center_lifts_only_idle_and_keeps_its_supply_flying():
    state, step = start()
    cap = int(production.food_cap(state.units))
    state, _ = select_cc(step, state)
    busy, _ = act(step, state, F.Train_SCV_quick("now"))
    _, ts = act(step, busy, F.Lift_quick("now"))
    assert result(ts) == ActionResult.CantQueueThatOrder
    state, ts = act(step, state, F.Lift_quick("now"))
    assert result(ts) == 0
    (cc,) = slots(state, UnitType.COMMAND_CENTER_FLYING)
    assert int(production.food_cap(state.units)) == cap
    assert F.Train_SCV_quick.id not in available(ts)
    # Sent to land where a depot then goes up before it arrives: its order ends there,
    # and it hovers.
    # (A Command Center keeps 3 cells from resources on this map at x 31.5-34.5, y 27.5.)
    site = (32.5, 27.5)
    state, ts = act(step, state, F.Land_screen("now", pixel(state, site)))
    assert result(ts) == 0 and int(state.units.orders[cc, 0]) == Order.LAND
    np.testing.assert_allclose(np.asarray(state.units.order_pos[cc, 0]), site)
    state = _with_units(state, [(UnitType.SUPPLY_DEPOT, (site[0] + 0.5, site[1] + 0.5))])
    state, _ = wait(step, state, 7)
    assert int(state.units.type[cc]) == UnitType.COMMAND_CENTER_FLYING
    assert int(state.units.orders[cc, 0]) == Order.NONE
    np.testing.assert_allclose(np.asarray(state.units.pos[cc]), site, atol=1e-3)
