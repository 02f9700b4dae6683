"""Exact combat scenes and the wave script of DefeatRoaches and DefeatZerglingsAndBanelings.

Scenes run the jitted game loop on hand-built units (no map step is compiled here);
numbers are the game's (reference/pysc2_facts.md §7): marine 6 damage, range 5, cooldown
13.7728 loops; roach 145 HP, armour 1, 16 damage, range 4, cooldown 32 loops; baneling
30 HP, Volatile Burst 20 (+15 against Light) in a 2.2 radius (centre to target edge);
marine and zergling radius 0.375, roach 0.5; weapon jitter -1..+2 loops per shot.
"""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS, to_dense
from sc2jax.environment.agents import random_action
from sc2jax.environment.engine.minigames import get_map
from sc2jax.environment.engine.minigames.wave_combat import (
    LEFT,
    MARINE_SLOTS,
    RIGHT,
    lineup_offset,
)
from sc2jax.environment.engine.rules.dynamics import LoopEvents, _cooldown_jitter, game_loop
from sc2jax.environment.engine.rules.state import Order, Outcome, Owner, place, place_where
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from tests.environment.helpers import (
    PARAMS,
    assert_trees_equal,
    compiled,
    map_params,
    random_actor,
    small_sim,
)

from .test_mechanics import make_units, with_orders

SLOTS = 8
PLAYABLE = (22.0, 20.0, 44.0, 36.0)
_LOOP = jax.jit(functools.partial(game_loop, playable=PLAYABLE, bursts=True))

M, Z, R, B = 1, 2, 3, 4  # UnitType: marine, zergling, roach, baneling.
SELF, ENEMY = Owner.SELF, Owner.ENEMY


def units_of(spec, orders=()):
    """Units from (slot, type, owner, (x, y)) rows; `orders` are (slot, Order, target
    slot or None, (x, y))."""
    units = make_units(SLOTS, [(s, t, o, xy, False) for s, t, o, xy in spec])
    return with_orders(units, orders)


def run(units, loops, seed=0):
    """Runs `loops` game loops; returns (units, [events per loop])."""
    key = jax.random.PRNGKey(seed)
    events = []
    for _ in range(loops):
        key, k = jax.random.split(key)
        units, e = _LOOP(units, k)
        events.append(jax.device_get(e))
    return units, events


def test_one_marine_shot_on_a_roach_is_reduced_by_its_armour():
    # Gap 5.0 - 0.875 = 4.125: in the marine's range (5), out of the roach's (4). Both
    # hold. One shot on loop 1: 6 - 1 armour = 5 damage; the roach cannot answer.
    units = units_of([(0, M, SELF, (28.0, 28.0)), (1, R, ENEMY, (33.0, 28.0))],
                     [(0, Order.HOLD, None, (28.0, 28.0)), (1, Order.HOLD, None, (33.0, 28.0))])
    after, events = run(units, 10)
    assert float(after.health[1]) == 140.0
    assert float(after.health[0]) == 45.0
    assert events[0].damage_dealt.tolist() == [5.0, 0.0]  # The player's, the enemy's.


def test_a_roach_kills_a_marine_in_three_shots():
    # 45 HP / 16 damage -> 29, 13, dead on the third shot. Shots come 32 loops plus a
    # jitter of -1..+2 apart: the third on loop 1 + ceil(64 + J), J in [-2, 4]: 63..69.
    # (The marine holds and shoots back; 5 damage a shot cannot kill the roach.)
    units = units_of([(0, M, SELF, (28.0, 28.0)), (1, R, ENEMY, (31.0, 28.0))],
                     [(0, Order.HOLD, None, (28.0, 28.0)),
                      (1, Order.ATTACK_UNIT, 0, (28.0, 28.0))])
    for seed in (1, 2, 3):
        _, events = run(units, 70, seed)
        died_on = [i + 1 for i, e in enumerate(events) if e.died[0]]
        taken = [float(e.damage_taken[0]) for e in events if e.damage_taken[0] > 0]
        assert taken == [16.0, 16.0, 16.0], taken
        assert len(died_on) == 1 and 63 <= died_on[0] <= 69, died_on


def test_baneling_burst_hits_a_clump_of_marines_but_not_its_own_side():
    # A baneling 0.85 from marine 0 (gap 0.1 <= its range 0.25) attacking it bursts on
    # loop 1 and dies: 20 + 15 (Light) = 35 to every marine whose edge is within 2.2 of
    # it (centres within 2.575). Marines 1 and 2 are inside, marine 3 outside (2.7). The
    # zergling beside it (its own side) takes nothing from it. The idle marines shoot
    # their nearest enemy: marines 0 and 1 the baneling, 2 and 3 the zergling (35 - 12).
    bane = (30.0, 28.0)
    units = units_of([
        (0, M, SELF, (30.85, 28.0)), (1, M, SELF, (30.0, 30.4)), (2, M, SELF, (28.0, 27.0)),
        (3, M, SELF, (27.3, 28.0)), (4, B, ENEMY, bane), (5, Z, ENEMY, (29.25, 28.0)),
    ], [(4, Order.ATTACK_UNIT, 0, (30.85, 28.0)), (5, Order.HOLD, None, (29.25, 28.0))])
    after, events = run(units, 1)
    np.testing.assert_array_equal(np.asarray(after.health[:4]), [10.0, 10.0, 10.0, 45.0])
    assert not bool(after.alive[4]) and bool(events[0].died[4])
    assert bool(after.alive[5]) and float(after.health[5]) == 23.0
    assert float(events[0].damage_taken[0]) == 3 * 35.0


def test_a_baneling_killed_at_range_still_bursts():
    # A 6-HP baneling holding 4 from marine 0 is shot dead on loop 1 and bursts where it
    # stands: marine 1 (1.5 away) takes 35, marine 0 (4 away) nothing.
    units = units_of([(0, M, SELF, (26.0, 28.0)), (1, M, SELF, (31.5, 28.0)),
                      (2, B, ENEMY, (30.0, 28.0))],
                     [(0, Order.HOLD, None, (26.0, 28.0)), (1, Order.MOVE, None, (31.5, 28.0)),
                      (2, Order.HOLD, None, (30.0, 28.0))])
    units = units.replace(health=units.health.at[2].set(6.0))
    after, events = run(units, 1)
    assert bool(events[0].died[2])
    assert float(after.health[0]) == 45.0 and float(after.health[1]) == 10.0


def test_idle_units_answer_an_attack_on_an_ally_within_their_acquisition_range():
    # The marine (holding) shoots roach 1, 4.5 away (gap 3.625). Roach 2, 4 beyond it
    # (gap 3 to roach 1, within its acquisition range 5; 7.625 to the marine, outside
    # it but within its sight 9) turns on the marine and closes in; roach 3, 6.1 beyond
    # roach 1 (gap 5.1), stays idle.
    units = units_of([(0, M, SELF, (26.0, 28.0)), (1, R, ENEMY, (30.5, 28.0)),
                      (2, R, ENEMY, (34.5, 28.0)), (3, R, ENEMY, (36.6, 28.0))],
                     [(0, Order.HOLD, None, (26.0, 28.0))])
    after, events = run(units, 1)
    assert float(after.health[1]) == 140.0
    assert np.asarray(after.target[1:4]).tolist() == [0, 0, -1]
    after, _ = run(after, 8)
    assert float(after.pos[2, 0]) < 34.0 and float(after.pos[3, 0]) == pytest.approx(36.6)
    assert int(after.target[3]) == -1


def test_cooldown_jitter_is_randints_draw():
    # One draw of bits gives randint's values (so episodes are those of randint's
    # stream), each of -1..2 about a quarter of the time.
    for seed in range(20):
        key = jax.random.PRNGKey(seed)
        expected = jax.random.randint(key, (28,), -1, 3).astype(jnp.float32)
        np.testing.assert_array_equal(_cooldown_jitter(key, 28), expected)
    counts = np.bincount(np.asarray(_cooldown_jitter(jax.random.PRNGKey(0), 4000) + 1,
                                    np.int32), minlength=4)
    assert len(counts) == 4 and counts.min() > 900


def test_combat_across_a_team_split_is_combat_over_all_pairs():
    # Marines in slots 0-3, Zerg in 4-7: with `team_split=4` the loop looks only at the
    # pairs across the split, and every loop of a brawl (acquisition, chases, bursts,
    # idle units answering attacks on allies, deaths) must come out bit for bit as over
    # all [N, N] pairs.
    split_loop = jax.jit(functools.partial(game_loop, playable=PLAYABLE, bursts=True,
                                           team_split=4))
    rng = np.random.default_rng(0)
    for trial in range(3):
        xy = [tuple(p) for p in rng.uniform((27.0, 25.0), (35.0, 31.0), (8, 2))]
        units = units_of([(i, M, SELF, xy[i]) for i in range(4)]
                         + [(4, Z, ENEMY, xy[4]), (5, B, ENEMY, xy[5]),
                            (6, R, ENEMY, xy[6]), (7, Z, ENEMY, xy[7])],
                         [(0, Order.ATTACK_MOVE, None, (40.0, 28.0)),
                          (1, Order.HOLD, None, xy[1]), (2, Order.ATTACK_UNIT, 6, xy[6]),
                          (5, Order.ATTACK_UNIT, 3, xy[3])])
        whole, split, key = units, units, jax.random.PRNGKey(trial)
        for _ in range(60):
            key, k = jax.random.split(key)
            whole, whole_events = _LOOP(whole, k)
            split, split_events = split_loop(split, k)
            for a, b in zip(jax.tree_util.tree_leaves((whole, whole_events)),
                            jax.tree_util.tree_leaves((split, split_events))):
                np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
        assert int(whole.alive.sum()) < 8  # The brawl killed someone.


# DefeatZerglingsAndBanelings runs DefeatRoaches' script (other units), so its step's
# compilation would add nothing here.
@pytest.mark.parametrize("name", map_params(["FindAndDefeatZerglings", "DefeatRoaches"]))
def test_each_side_stays_on_its_side_of_the_team_split(name):
    # The maps that declare `team_split` keep one side's units before it and the
    # other's after it (FindAndDefeatZerglings the player's first, the wave maps the
    # enemy's), through play and a respawn or wave reset (every enemy killed at step 6).
    sim = small_sim(name)
    split = sim.game.team_split
    reset, step = compiled(sim)
    state, ts = reset(jax.random.PRNGKey(2), PARAMS)
    act = jax.jit(functools.partial(random_action, types=sim.fmt.types))
    key, states = jax.random.PRNGKey(3), [state]
    for i in range(12):
        if i == 6:
            state = state.replace(units=state.units.replace(
                alive=state.units.alive & (state.units.owner != ENEMY)))
        key, k = jax.random.split(key)
        state, ts = step(state, act(k, ts.observation["available_actions_mask"]), PARAMS)
        states.append(state)
    assert bool((states[7].units.alive & (states[7].units.owner == ENEMY)).any())
    front, back = (SELF, ENEMY) if name == "FindAndDefeatZerglings" else (ENEMY, SELF)
    for s in states:
        alive, owner = np.asarray(s.units.alive), np.asarray(s.units.owner)
        assert (owner[:split][alive[:split]] == front).all()
        assert (owner[split:][alive[split:]] == back).all()


@functools.cache
def _script(name):
    game = get_map(name)
    return game, jax.jit(game.init), jax.jit(game.on_loop)


def _state(name, seed=0):
    """A reset state of a wave map, built without compiling the map's step."""
    return jax.jit(small_sim(name)._initial_state)(jax.random.PRNGKey(seed))


def test_initial_lineup_and_sides():
    game, init, _ = _script("DefeatRoaches")
    for seed in range(4):
        units, _, tag = init(jax.random.PRNGKey(seed))
        pos = np.asarray(units.pos)
        alive = np.asarray(units.alive)
        # The four roaches, then nine of the 64 marine slots.
        assert game.num_slots == 4 + MARINE_SLOTS and game.team_split == 4
        assert alive[:13].all() and not alive[13:].any()
        assert np.asarray(units.selected[4:13]).all() and int(tag) == 13
        np.testing.assert_array_equal(units.tag[:13], [9, 10, 11, 12] + list(range(9)))
        marines, roaches = pos[4:13], pos[:4]
        np.testing.assert_allclose(marines[:, 0], marines[0, 0])
        np.testing.assert_allclose(marines[:, 1] - marines[0, 1], [0, 1, -1, 2, -2, 3, -3, 4, -4],
                                   atol=1e-5)
        np.testing.assert_allclose(roaches[:, 1] - roaches[0, 1], [0, 1, -1, -2], atol=1e-5)
        left, right = (marines, roaches) if marines[0, 0] < 32 else (roaches, marines)
        base_left = left[0] - [0, 0.5 if left is roaches else 0]
        base_right = right[0] - [0, 0.5 if right is roaches else 0]
        assert LEFT[0] <= base_left[0] <= LEFT[2] and LEFT[1] <= base_left[1] <= LEFT[3]
        assert RIGHT[0] <= base_right[0] <= RIGHT[2] and RIGHT[1] <= base_right[1] <= RIGHT[3]
    assert lineup_offset(np.arange(9)).tolist() == [0, 1, -1, 2, -2, 3, -3, 4, -4]


@pytest.mark.parametrize("name,reward,fresh", [("DefeatRoaches", 10, 5),
                                               ("DefeatZerglingsAndBanelings", 5, 4)])
def test_wave_reset_keeps_survivors_health(name, reward, fresh):
    game, _, on_loop = _script(name)
    state = _state(name)
    units = state.units
    n, first = game.num_slots, game.team_split
    m = first + np.arange(12)  # The first 12 marine slots.
    # Marines 2 and 5 died earlier; marine 1 is hurt; this loop the last enemies and
    # marine 7 die.
    alive = np.asarray(units.alive).copy()
    alive[m[[2, 5, 7]]] = False
    alive[:first] = False
    health = np.asarray(units.health).copy()
    health[m[1]], health[m[8]] = 17.0, 3.0
    died = np.zeros(n, bool)
    died[:first] = True
    died[m[7]] = True
    old_tags = np.asarray(units.tag)
    state = state.replace(units=units.replace(alive=jnp.asarray(alive),
                                              health=jnp.asarray(health)),
                          score=jnp.int32(100))
    new = on_loop(state, LoopEvents.none(n, died))
    assert first == len(game.ENEMIES)
    assert int(new.score) == 100 + reward * first - 1
    assert int(new.outcome) == Outcome.RUNNING
    u = jax.device_get(new.units)
    marines = np.flatnonzero(u.alive[first:]) + first
    # Six survivors (0, 1, 3, 4, 6, 8) keep their health; the fresh ones fill the first
    # free slots at full health.
    kept = m[[0, 1, 3, 4, 6, 8]]
    assert marines.tolist() == sorted(kept.tolist() + m[[2, 5, 7, 9, 10, 11][:fresh]].tolist())
    assert u.health[kept].tolist() == [45.0, 17.0, 45.0, 45.0, 45.0, 3.0]
    assert (u.health[marines] == 45.0).sum() == 4 + fresh
    # Replaced: new tags, survivors first; all selected, idle, in one line.
    tags = u.tag[marines]
    assert tags.min() > old_tags.max() and len(set(tags.tolist())) == len(marines)
    assert u.tag[kept].tolist() == sorted(u.tag[kept].tolist())
    assert u.selected[marines].all() and not u.selected[:first].any()
    assert (u.orders[marines] == Order.NONE).all()
    np.testing.assert_allclose(u.pos[marines, 0], u.pos[marines[0], 0])
    # A new wave at full health on the other side.
    assert u.alive[:first].all()
    np.testing.assert_array_equal(u.health[:first], [
        {3: 145.0, 2: 35.0, 4: 30.0}[t] for t in u.type[:first]])
    assert (u.pos[0, 0] < 32) != (u.pos[marines[0], 0] < 32)
    assert int(new.next_tag) == int(state.next_tag) + len(marines) + first
    # The empty marine slots are left as they were.
    empty = np.setdiff1d(np.arange(first, n), marines)
    for before, after in zip(jax.tree_util.tree_leaves(jax.device_get(units)),
                             jax.tree_util.tree_leaves(u)):
        np.testing.assert_array_equal(np.asarray(before)[empty], np.asarray(after)[empty])


def test_place_where_creates_what_place_creates_without_a_scatter():
    units = _state("DefeatRoaches").units
    n = units.num_slots
    slots = np.array([3, 9, 20])
    types = np.array([R, M, M], np.int32)
    pos = np.array([[30.0, 28.0], [25.0, 27.5], [26.0, 29.0]], np.float32)
    placed, tag = place(units, slots, types, Owner.SELF, pos, 40, selected=True)
    where = np.zeros(n, bool)
    where[slots] = True
    every_type = np.full(n, Z, np.int32)  # Unused where not placed.
    every_type[slots] = types
    every_pos = np.zeros((n, 2), np.float32)
    every_pos[slots] = pos
    tags = np.zeros(n, np.int32)
    tags[slots] = 40 + np.arange(3)
    args = (where, every_type, Owner.SELF, every_pos, tags, True)
    assert_trees_equal(place_where(units, *args), placed)
    assert int(tag) == 43
    assert "scatter" not in jax.jit(place_where).lower(units, *args).as_text()
    # The wave reset, which runs inside the game loop, creates its units so.
    game = get_map("DefeatZerglingsAndBanelings")
    hlo = jax.jit(game.wave_reset).lower(_state("DefeatZerglingsAndBanelings")).as_text()
    assert "scatter" not in hlo


def test_wave_reset_adds_only_what_the_slots_hold_and_defeat_comes_first():
    game, _, on_loop = _script("DefeatRoaches")
    state = _state("DefeatRoaches", seed=1)
    n, first = game.num_slots, game.team_split
    alive = np.zeros(n, bool)
    alive[first:n - 2] = True
    died = np.zeros(n, bool)
    died[:first] = True
    full = state.replace(units=state.units.replace(alive=jnp.asarray(alive)))
    new = on_loop(full, LoopEvents.none(n, died))
    assert int(np.asarray(new.units.alive[first:]).sum()) == MARINE_SLOTS
    # The last marine and the last roach die on the same loop: defeat, no new wave.
    dead = state.replace(units=state.units.replace(alive=jnp.zeros(n, bool)))
    died[first:first + 9] = True
    new = on_loop(dead, LoopEvents.none(n, died))
    assert int(new.outcome) == Outcome.DEFEAT
    assert int(new.score) == 40 - 9
    assert not np.asarray(new.units.alive).any()


def _wave_about_to_come(extra: int):
    """A DefeatRoaches state with 9 + `extra` marines (slots 4 on) whose roaches are all
    dead: the next loop's wave adds 5 marines."""
    state = _state("DefeatRoaches", seed=3)
    units, tag = place(state.units, 13 + np.arange(extra), M, SELF,
                       state.units.pos[4:4 + extra] + jnp.asarray([2.0, 0.0]), state.next_tag)
    return state.replace(units=units.replace(alive=units.alive.at[:4].set(False)),
                         next_tag=tag)


@functools.cache
def _every_slot_step():
    """DefeatRoaches' jitted step on all of its slots."""
    return compiled(small_sim("DefeatRoaches"))[1]


@pytest.mark.slow  # About 15-20 s on 2 cores: the fast tier stays under 3 minutes.
def test_wave_maps_play_on_their_leading_slots_as_on_all_slots():
    """DefeatRoaches runs its game loops and observation on the roaches and the leading
    marine slots in use (`slot_sizes` 4 + (16, 64)), with room for a wave's 5
    reinforcements: 9 marines before a wave that makes 14 need 18 slots, so the step
    runs on 20, and plays and is observed bit for bit as on all 68
    (`use_slot_sizes=False`), and so do random steps after it."""
    sim = small_sim("DefeatRoaches", sized=True)
    leading = compiled(sim)[1]
    state = _wave_about_to_come(0)
    assert sim.game.slot_sizes == (20, 68)
    assert int(jax.jit(sim.slots_needed)(state.units)) == 13 + 5
    act = random_actor(sim.fmt.types)
    a = b = state
    ts = None
    for i in range(6):
        action = act(jax.random.PRNGKey(i), ts.observation["available_actions_mask"]) if ts else (
            to_dense(FUNCTIONS.no_op(), sim.fmt.types))
        (a, ts), (b, ts_b) = leading(a, action, PARAMS), _every_slot_step()(b, action, PARAMS)
        assert_trees_equal((a, ts), (b, ts_b))
        if i == 0:
            assert int(a.units.alive[4:].sum()) == 14 and bool(a.units.alive[:4].all())


@pytest.mark.slow
def test_a_run_whose_last_slot_fills_runs_again_on_more_slots():
    """With 14 marines and no room for the wave's reinforcements, the step is first
    tried on 20 slots (16 for 19 marines), where the wave fills the last slot: the run
    is tried again on all 68 and matches the game there (`Simulator.advance`, against
    the state of the step on all slots)."""
    sim = dataclasses.replace(small_sim("DefeatRoaches", sized=True))  # A game of its own.
    object.__setattr__(sim.game, "spawn_room", 0)
    state = _wave_about_to_come(5)
    assert int(jax.jit(sim.slots_needed)(state.units)) == 18
    action = to_dense(FUNCTIONS.no_op(), sim.fmt.types)
    leading = jax.jit(sim.advance)(state, action)
    assert_trees_equal(leading, _every_slot_step()(state, action, PARAMS)[0])
    assert int(leading.units.alive[4:].sum()) == 19


_AIR_LOOP = jax.jit(functools.partial(game_loop, playable=PLAYABLE, air=True))


@pytest.mark.parametrize("attacker, hits", [
    (UnitType.VIKING_FIGHTER, {UnitType.MEDIVAC}), (UnitType.SIEGE_TANK, {UnitType.MARINE}),
    (UnitType.MARINE, {UnitType.MEDIVAC, UnitType.MARINE})], ids=lambda v: getattr(v, "name", ""))
def test_weapons_hit_only_the_layers_they_target(attacker, hits):
    # Each attacker holds 3 from an enemy in the air (a Medivac) or on the ground (a
    # Marine, holding too); with `air`, it fires only at what its weapon targets, and an
    # order to attack what it cannot hit ends.
    for enemy in (UnitType.MEDIVAC, UnitType.MARINE):
        units = units_of([(0, attacker, SELF, (28.0, 28.0)), (1, enemy, ENEMY, (31.0, 28.0))],
                         [(0, Order.HOLD, None, (28.0, 28.0)),
                          (1, Order.HOLD, None, (31.0, 28.0))])
        key = jax.random.PRNGKey(0)
        for _ in range(40):
            key, k = jax.random.split(key)
            units, _ = _AIR_LOOP(units, k)
        hurt = float(units.health[1]) < UNIT_DATA.max_health[enemy]
        assert hurt == (enemy in hits), (attacker.name, enemy.name)
        ordered = units_of([(0, attacker, SELF, (28.0, 28.0)), (1, enemy, ENEMY, (31.0, 28.0))],
                           [(0, Order.ATTACK_UNIT, 1, (31.0, 28.0))])
        ordered, _ = _AIR_LOOP(ordered, key)
        assert (int(ordered.orders[0, 0]) == Order.ATTACK_UNIT) == (enemy in hits)


@pytest.mark.parametrize("depot, passes", [(UnitType.SUPPLY_DEPOT, False),
                                           (UnitType.SUPPLY_DEPOT_LOWERED, True)],
                         ids=["raised", "lowered"])
def test_a_marine_walks_over_a_lowered_depot_and_not_through_a_raised_one(depot, passes):
    units = units_of([(0, M, SELF, (27.0, 28.0)), (1, depot, SELF, (30.0, 28.0))],
                     [(0, Order.MOVE, None, (33.0, 28.0))])
    after, _ = run(units, 60)
    x = float(after.pos[0, 0])
    assert (x == pytest.approx(33.0, abs=1e-3)) == passes, x
    assert passes or x < 30.0  # Held on the depot's near side.
