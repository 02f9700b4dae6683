"""Melee maps (`minigames.melee`) and the two players (`rules.players`): the start of a
melee game on each ladder map's layout, the mirror between the players' views, both
players acting from their own observations (`Simulator.step_both`, and two agents
through `make(num_agents=2)`), the outcome, the 30-minute tie, and determinism.

The start and the mirror are checked on eagerly built states; the steps run the
Acropolis melee game on every slot of 256 (`Simulator.num_slots`: room for 70 more units
than the start's; compiled once, in the slow tier).
"""


import dm_env
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS, make
from sc2jax.environment.engine import ladder
from sc2jax.environment.engine.compiled import compiled_both, simulator
from sc2jax.environment.engine.minigames import get_map, melee
from sc2jax.environment.engine.rules import dynamics, players, production
from sc2jax.environment.engine.rules.research import Research
from sc2jax.environment.engine.rules.state import Order, Outcome, Owner, place
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.dense import to_dense
from sc2jax.environment.interface.map_names import LADDER_MAPS
from tests.environment.helpers import PARAMS, SMALL, SMALL_MAKE, assert_trees_equal

F = FUNCTIONS
MAP = "Acropolis"


def sim(score_index=-1):
    """The simulator `make(MAP, num_slots=256, num_agents=2, **SMALL_MAKE)` makes (the
    outcome reward, every slot), so that the environment's test shares its programs."""
    return simulator(MAP, SMALL, 8, score_index, 1.0, 1.0, False, False, 256)


def step_both():
    return compiled_both(sim())[1]


def dense(call):
    return to_dense(call, SMALL.types)


def owned(units, owner, unit_type):
    units = jax.device_get(units)
    return np.flatnonzero(units.alive & (units.owner == owner) & (units.type == unit_type))


@pytest.mark.parametrize("seed", [0, 3])  # The player at the first start, at the second.
def test_each_player_starts_with_a_command_center_12_mining_scvs_and_50_minerals(seed):
    game = get_map(MAP)
    layout = ladder.load_layout(melee.LAYOUT_OF[MAP])
    state = sim()._initial_state(jax.random.PRNGKey(seed))
    units = jax.device_get(state.units)
    starts = np.asarray(layout.start_locations)
    homes = []
    for owner in (Owner.SELF, Owner.ENEMY):
        (cc,) = owned(units, owner, UnitType.COMMAND_CENTER)
        home = int(np.argmin(np.abs(starts - units.pos[cc]).sum(-1)))
        np.testing.assert_array_equal(units.pos[cc], starts[home])
        homes.append(home)
        scvs = owned(units, owner, UnitType.SCV)
        assert len(scvs) == 12
        np.testing.assert_allclose(np.linalg.norm(units.pos[scvs] - units.pos[cc], axis=-1),
                                   melee.SCV_RING, rtol=1e-5)
        # Mining, as the game sends them at the start: on the 8 fields of their base,
        # one or two to a field.
        assert (units.orders[scvs, 0] == Order.GATHER).all()
        field = units.order_unit[scvs, 0]
        assert (units.type[field] == UnitType.MINERAL_FIELD).all()
        assert (np.linalg.norm(units.pos[field] - units.pos[cc], axis=-1) < 10).all()
        assert sorted(np.bincount(field)[np.unique(field)]) == [1] * 4 + [2] * 4
    assert sorted(homes) == [0, 1]
    # Each camera on its own start location; the other's view is the mirror.
    np.testing.assert_array_equal(state.camera, starts[homes[0]])
    np.testing.assert_array_equal(state.other.camera, starts[homes[1]])
    assert (int(state.minerals), int(state.other.minerals)) == (50, 50)
    assert int(state.other.player_id) == 2 and int(players.player_id(state)) == 1
    # Every mineral field and geyser of the layout, with its game contents.
    fields = owned(units, Owner.NEUTRAL, UnitType.MINERAL_FIELD)
    np.testing.assert_array_equal(units.pos[fields], [m[:2] for m in layout.minerals])
    small = np.array(["750" in m[2] for m in layout.minerals])
    np.testing.assert_array_equal(units.contents[fields], np.where(small, 900, 1800))
    geysers = owned(units, Owner.NEUTRAL, UnitType.VESPENE_GEYSER)
    np.testing.assert_array_equal(units.pos[geysers], [g[:2] for g in layout.geysers])
    assert (units.contents[geysers] == 2250).all()
    assert game.field_slots == len(fields) and units.alive.sum() == len(fields) + len(
        geysers) + 26
    # Each player's score is its Blizzard score: 50 minerals, the Command Center's 400
    # and 12 SCVs' 50 each.
    assert int(state.score) == int(state.other.score) == 50 + 400 + 12 * 50


def test_both_start_locations_are_drawn():
    game = get_map(MAP)
    draws = [int(game.init(jax.random.PRNGKey(s))[1]) for s in range(16)]
    assert set(draws) == {0, 1}


@pytest.mark.parametrize("name", LADDER_MAPS)
def test_every_ladder_map_is_playable_with_its_layout(name):
    game = get_map(name)
    layout = game.layout
    geometry = game.geometry
    assert geometry.size == layout.map_size
    w, h = layout.map_size
    assert geometry.buildable.shape == geometry.pathable.shape == (h, w)
    assert not (geometry.buildable & ~geometry.pathable).any()
    # A Command Center fits at each start location: its 5 x 5 footprint is buildable.
    for x, y in layout.start_locations:
        rows = h - 1 - (int(np.floor(y)) + np.arange(-2, 3))
        cols = int(np.floor(x)) + np.arange(-2, 3)
        assert geometry.buildable[np.ix_(rows, cols)].all(), (name, x, y)
    assert game.players == 2 and game.fog and game.timer_outcome == Outcome.TIE
    assert game.time_limit_loops == 28_800  # PySC2's ladder maps' 30 minutes.
    # The bases: each start location is a base site, exactly (by the game's town-hall
    # placement rule, which no start location was fitted to); each base has its 8
    # mineral fields and 2 geysers (7 on King's Cove's two gold bases), and the
    # natural is another base, 20 to 45 units from home.
    bases = game.bases
    starts = np.asarray(layout.start_locations, np.float32)
    assert (np.linalg.norm(bases[:, None] - starts[None], axis=-1).min(0) == 0).all()
    points = np.array([r[:2] for r in layout.minerals + layout.geysers], np.float32)
    sizes = np.bincount(melee.resource_groups(points))
    assert set(sizes) <= {7, 9, 10} and len(bases) <= len(sizes), sizes
    naturals = np.asarray(game.naturals(jnp.int32(0)))
    assert (20 <= np.linalg.norm(naturals - starts, axis=-1)).all()
    assert (np.linalg.norm(naturals - starts, axis=-1) <= 45).all()


def test_a_command_center_keeps_its_clearance_from_resources_but_on_the_diagonal():
    cc, field = np.float32([5, 5]), np.float32([[2, 1]])
    near = lambda dx, dy: bool(production.near_resources(  # noqa: E731
        np.float32([0.0, 0.0]), cc, np.float32([[dx, dy]]), field)[0])
    # Gaps across (x) and along (y) between the footprints: 3.5 + gap, 3 + gap.
    assert near(3.5 + 2.9, 0.0) and not near(3.5 + 3.0, 0.0)
    assert near(0.0, 3.0 + 2.9) and not near(0.0, 3.0 + 3.0)
    assert not near(3.5 + 2.0, 3.0 + 2.0)  # Cut corner: 2 cells off both ways.
    assert near(3.5 + 1.9, 3.0 + 2.5) and near(3.5 + 2.5, 3.0 + 1.9)


def test_close_holes_fills_gaps_and_keeps_the_outline():
    cells = np.zeros((7, 9), bool)
    cells[1:6, 1:8] = True
    cells[3, 4] = False  # A hole.
    closed = melee.close_holes(cells)
    expected = np.zeros_like(cells)
    expected[1:6, 1:8] = True
    np.testing.assert_array_equal(closed, expected)


def test_the_mirror_swaps_the_players_and_is_its_own_inverse():
    state = sim()._initial_state(jax.random.PRNGKey(0))
    state = state.replace(minerals=jnp.int32(75), outcome=jnp.int32(Outcome.VICTORY),
                          units=state.units.replace(selected=state.units.alive
                                                    & (state.units.owner == Owner.SELF)))
    seen = players.mirror(state)
    assert int(seen.minerals) == 50 and int(seen.other.minerals) == 75
    assert int(seen.outcome) == Outcome.DEFEAT
    assert int(players.player_id(seen)) == 2
    np.testing.assert_array_equal(seen.camera, state.other.camera)
    units, mirrored = jax.device_get(state.units), jax.device_get(seen.units)
    np.testing.assert_array_equal(mirrored.owner == Owner.SELF, units.owner == Owner.ENEMY)
    np.testing.assert_array_equal(mirrored.owner == Owner.NEUTRAL, units.owner == Owner.NEUTRAL)
    assert not mirrored.selected.any()  # The other player selected nothing.
    assert_trees_equal(players.mirror(seen), state)
    with pytest.raises(ValueError, match="two-player state"):
        players.mirror(Simulator("MoveToBeacon", SMALL)._initial_state(jax.random.PRNGKey(0)))


def test_num_slots_resizes_melee_games_only():
    game = Simulator(MAP, SMALL, num_slots=1000).game
    assert game.num_slots == 1000 and game.slot_sizes == (256, 512, 768, 1000)
    assert get_map(MAP).slot_sizes == melee.SLOT_SIZES
    with pytest.raises(ValueError, match=r"num_slots must be an int in \[187, 4096\] on "
                                         r"Acropolis .*got 186"):
        Simulator(MAP, SMALL, num_slots=186)
    with pytest.raises(ValueError, match="num_slots applies to melee maps; MoveToBeacon"):
        Simulator("MoveToBeacon", SMALL, num_slots=256)


def test_one_player_maps_take_no_other_action():
    beacon = Simulator("MoveToBeacon", SMALL)
    state = beacon._initial_state(jax.random.PRNGKey(0))
    with pytest.raises(ValueError, match="other_action applies to two-player maps"):
        beacon.step(state, dense(F.no_op()), other_action=dense(F.no_op()))
    with pytest.raises(ValueError, match="step_both needs a two-player map"):
        beacon.step_both(state, (dense(F.no_op()), dense(F.no_op())))


def _start(seed=0):
    state, _ = compiled_both(sim())[0](jax.random.PRNGKey(seed), PARAMS)
    return state


@pytest.mark.slow
def test_each_player_acts_from_its_own_view():
    step = step_both()
    state = _start()
    noop = dense(F.no_op())
    # The other player selects its Command Center (under its camera's centre) and trains
    # an SCV from its bank; the player's bank is untouched.
    state, (mine, theirs) = step(state, (noop, dense(F.select_point("select", (16, 16)))),
                                 PARAMS)
    assert int(theirs.observation["player"][0]) == 2
    assert int(mine.observation["player"][0]) == 1
    cc = owned(state.units, Owner.ENEMY, UnitType.COMMAND_CENTER)
    np.testing.assert_array_equal(np.flatnonzero(np.asarray(state.other.selected)), cc)
    assert not np.asarray(state.units.selected).any()
    assert int(theirs.observation["single_select"][0, 0]) == UNIT_DATA.sc2_id[
        UnitType.COMMAND_CENTER]
    state, (mine, theirs) = step(state, (noop, dense(F.Train_SCV_quick("now"))), PARAMS)
    assert (int(state.minerals), int(state.other.minerals)) == (50, 0)
    # An SCV trains in 272 game loops (34 steps of 8).
    for _ in range(35):
        state, (mine, theirs) = step(state, (noop, noop), PARAMS)
    assert len(owned(state.units, Owner.ENEMY, UnitType.SCV)) == 13
    assert len(owned(state.units, Owner.SELF, UnitType.SCV)) == 12
    assert int(theirs.observation["player"][6]) == 13  # food_workers
    assert int(mine.observation["player"][6]) == 12
    # Spending is no loss: the SCV is worth its 50 minerals. Both banks grew by mining.
    assert int(state.score) == int(state.minerals) + 400 + 12 * 50
    assert int(state.other.score) == int(state.other.minerals) + 400 + 13 * 50
    assert int(state.minerals) > 50 and int(state.other.minerals) > 0


@pytest.mark.slow
def test_a_player_without_structures_loses_and_the_timer_ties():
    step = step_both()
    noop = (dense(F.no_op()), dense(F.no_op()))
    start = _start()
    units = start.units
    enemy_structures = (units.owner == Owner.ENEMY) & (units.type == UnitType.COMMAND_CENTER)
    razed = start.replace(units=units.replace(alive=units.alive & ~enemy_structures))
    after, (mine, theirs) = step(razed, noop, PARAMS)
    assert int(after.outcome) == Outcome.VICTORY
    assert int(mine.step_type) == int(theirs.step_type) == 2  # LAST
    assert float(mine.discount) == float(theirs.discount) == 0.0
    outcome = sim()
    assert float(outcome._reward(razed, after, True)) == 1.0
    assert float(outcome._reward(players.mirror(razed), players.mirror(after), True)) == -1.0
    # The 30-minute limit (28,800 game loops) ends the game in a tie.
    late = start.replace(game_loop=jnp.int32(28_800 - 8))
    after, (mine, _) = step(late, noop, PARAMS)
    assert int(after.outcome) == Outcome.TIE and int(mine.step_type) == 2
    assert float(outcome._reward(late, after, True)) == 0.0


@pytest.mark.slow
def test_a_melee_game_is_deterministic_bit_for_bit():
    step = step_both()
    calls = [(F.select_rect("select", (0, 0), (31, 31)), F.select_point("select", (16, 16))),
             (F.Harvest_Gather_screen("now", (10, 10)), F.Train_SCV_quick("now")),
             (F.Move_screen("now", (30, 2)), F.no_op())]
    runs = []
    for _ in range(2):
        state = _start(seed=5)
        for mine, theirs in calls + [(F.no_op(), F.no_op())] * 5:
            state, timesteps = step(state, (dense(mine), dense(theirs)), PARAMS)
        runs.append((state, timesteps))
    assert_trees_equal(runs[0], runs[1])


@pytest.mark.slow
def test_two_agents_play_one_game_through_make():
    env = make(MAP, num_slots=256, num_agents=2, seed=2, **SMALL_MAKE)
    assert env.simulator is sim()  # Shares the programs of the tests above.
    first, second = env.reset()
    assert first.step_type == second.step_type == dm_env.StepType.FIRST
    assert (first.observation["player"].player_id,
            second.observation["player"].player_id) == (1, 2)
    with pytest.raises(ValueError, match="function 490/Train_SCV_quick is not available"):
        env.step((F.no_op(), F.Train_SCV_quick("now")))
    assert F.select_idle_worker.id not in first.observation["available_actions"]  # Mining.
    first, second = env.step((F.select_rect("select", (0, 0), (31, 31)), F.no_op()))
    assert first.step_type == second.step_type == dm_env.StepType.MID
    assert len(first.observation["multi_select"]) == 12  # Its 12 SCVs, not the structure.
    assert len(second.observation["multi_select"]) == 0
    # Player 2 selects its Command Center at the centre of its screen, and trains an SCV.
    first, second = env.step((F.no_op(), F.select_point("select", (16, 16))))
    assert second.observation["single_select"][0].unit_type == 18  # A Command Center.
    first, second = env.step((F.no_op(), F.Train_SCV_quick("now")))
    assert (first.observation["player"].minerals, second.observation["player"].minerals) == (
        50, 0)
    assert len(second.observation["build_queue"]) == 1
    assert first.reward == second.reward == 0.0 and first.observation["game_loop"][0] == 24
    with pytest.raises(ValueError, match="step takes one action per agent"):
        env.step(F.no_op())


def test_two_agents_need_a_ladder_map_of_the_simulator():
    with pytest.raises(ValueError, match="num_agents=2 plays two agents in one game of a "
                                         "ladder map"):
        make("MoveToBeacon", num_agents=2)
    with pytest.raises(ValueError, match="num_agents must be 1 or 2, got 3"):
        make(MAP, num_agents=3)


def test_a_resource_slot_is_never_reused():
    game = get_map(MAP)
    units, _, _ = game.init(jax.random.PRNGKey(0))
    geyser = game.field_slots  # The first geyser; a Refinery over it kills it.
    units = units.replace(alive=units.alive.at[jnp.asarray([0, geyser])].set(False))
    assert int(production.free_slots(units, 1)[0]) == game.start_units


@pytest.mark.slow
def test_the_resource_slots_are_left_out_of_the_pairs_exactly():
    """Combat, collisions and harvesting on the slots after the resources
    (`MiniGame.resource_slots`) move every unit exactly as over all pairs: two lines of
    30 Marines fight beside SCVs mining, bit for bit (the resources neither fight nor
    move)."""
    game = get_map(MAP)
    units, _, tag = game.init(jax.random.PRNGKey(3))
    units = jax.tree.map(lambda x: x[:256], units)
    first = game.start_units
    for side, owner in enumerate((Owner.SELF, Owner.ENEMY)):
        grid = np.stack(np.meshgrid(np.arange(-5.0, 5.0), np.arange(3.0)), -1).reshape(-1, 2)
        line = np.float32([88, 86]) + grid * (1, 2 * side - 1) + (0, 2 * side - 1)
        units, tag = place(units, first + 30 * side + np.arange(30), UnitType.MARINE, owner,
                           jnp.asarray(line, jnp.float32), tag)
    fields = np.flatnonzero(np.asarray(units.type == UnitType.MINERAL_FIELD))
    scvs = np.flatnonzero(np.asarray(units.alive & (units.type == UnitType.SCV)))
    pos = np.asarray(units.pos)
    nearest = fields[np.argmin(np.linalg.norm(pos[scvs, None] - pos[fields], axis=-1), 1)]
    units = units.replace(orders=units.orders.at[scvs, 0].set(Order.GATHER),
                          order_unit=units.order_unit.at[scvs, 0].set(nearest))
    researched = jnp.zeros((2, len(Research)), bool)

    def run(static_slots):
        def loop(i, u):
            return dynamics.game_loop(
                u, jax.random.PRNGKey(i), game.geometry.playable, workers=True,
                field_slots=game.field_slots, static_slots=static_slots,
                jitter_slots=game.num_slots, sized=True, air=True, researched=researched)[0]
        return jax.jit(lambda u: jax.lax.fori_loop(0, 200, loop, u))(units)

    every, after = run(None), run(game.resource_slots)
    assert_trees_equal(every, after)
    marines = every.alive & (every.type == UnitType.MARINE)
    assert 0 < int(marines.sum()) < 50  # They fought.
    assert float(every.contents[fields].sum()) < float(units.contents[fields].sum())
