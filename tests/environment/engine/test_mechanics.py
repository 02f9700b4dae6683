"""Small exact scenes for the simulator's mechanics, worked by hand from the game's data.

Each scene takes a reset state of a mini-game, replaces its units (and camera), and
steps it with the compiled step shared by every test of that map (`conftest.compiled`).
Unit stats are the game's (reference/pysc2_facts.md §7) at 16 game loops per second:

- marine speed 2.25 units/game-s = 2.25 / 16 = 0.140625 units per loop, so one agent
  step of 8 loops moves a marine 1.125;
- marine weapon: 6 damage, range 5 (edge to edge), cooldown 0.8608 game-s = 13.7728
  loops, plus a jitter of -1..+2 loops per shot; radius 0.375;
- zergling: 35 HP, armour 0, 5 damage, melee range 0.1, radius 0.375.

Screen pixels follow PySC2: the screen is 24 world units wide and centred on the camera,
pixel = (world - camera) * res / 24 + res / 2 with y flipped. At res 32 a pixel is 0.75
world units, so the world point at the centre of pixel (px, py) is
(cx + (px + 0.5 - 16) * 0.75, cy - (py + 0.5 - 16) * 0.75). Units below stand at pixel
centres so that clicks and unit lists land on known pixels.
"""

import functools
from unittest import mock

import dm_env
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS, ActionResult, FeatureUnit, make, to_dense
from sc2jax.environment.agents import random_action
from sc2jax.environment.engine.compiled import simulator
from sc2jax.environment.engine.minigames import get_map
from sc2jax.environment.engine.render import sight_grid
from sc2jax.environment.engine.rules import dynamics
from sc2jax.environment.engine.rules.dynamics import LoopEvents, colliding, game_loop
from sc2jax.environment.engine.rules.state import DEFAULT_FACING, Order, Owner, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from tests.environment.helpers import (
    PARAMS,
    SMALL_MAKE,
    assert_trees_equal,
    compiled,
    random_play,
    small_sim,
)

# Every stepped scene is on FindAndDefeatZerglings (28 slots, free camera), so the file
# compiles one map's step (shared with the other test files). The other two maps' scripts
# are pure functions of the state, tested directly.
MAP = "FindAndDefeatZerglings"
BEACON_MAP = "MoveToBeacon"
SHARDS_MAP = "CollectMineralShards"

MARINE_ID, ZERGLING_ID, SCV_ID = 48, 105, 45  # StarCraft II unit ids.
SPEED = 2.25 / 16  # Marine, world units per loop.
MARINE_CARD = {0, 1, 2, 3, 4, 7, 12, 13, 274, 331, 332, 333, 334, 451, 452, 453}
UI_ONLY = {0, 1, 2, 3, 4, 7}  # No selection, but an army exists (select_army).
CAM = (32.0, 25.0)  # The map's camera.
FAR = (52.0, 42.0)  # A zergling on hold here keeps the map from respawning zerglings.

# One game loop, jitted once for the whole module (the map's 28 slots).
_GAME_LOOP = jax.jit(game_loop, static_argnums=2)


@functools.cache
def script(map_name):
    """A map's script, with its `on_loop` and `on_step` jitted once."""
    game = get_map(map_name)
    return game, jax.jit(game.on_loop), jax.jit(game.on_step)


def pixel_centre(camera, px, py):
    """The world point at the centre of screen pixel (px, py) at res 32."""
    return (camera[0] + (px + 0.5 - 16) * 0.75, camera[1] - (py + 0.5 - 16) * 0.75)


@functools.cache
def _template():
    """A reset state of the map (compiled once), to replace the units of."""
    reset, _ = compiled(small_sim(MAP))
    return reset(jax.random.PRNGKey(0), PARAMS)[0]


def make_units(num_slots, units_spec):
    """Units complete, at full health, idle, facing the default way, with their resources;
    built in numpy so that no test compiles scatter ops for it."""
    units = jax.tree_util.tree_map(np.array, jax.device_get(Units.empty(num_slots)))
    for slot, unit_type, owner, xy, selected in units_spec:
        units.alive[slot], units.type[slot], units.owner[slot] = True, unit_type, owner
        units.tag[slot], units.pos[slot], units.selected[slot] = slot, xy, selected
        units.health[slot] = UNIT_DATA.max_health[unit_type]
        units.facing[slot] = DEFAULT_FACING
        units.progress[slot] = UNIT_DATA.build_time[unit_type]
        units.contents[slot] = UNIT_DATA.contents[unit_type]
    return jax.tree_util.tree_map(jnp.asarray, units)


def with_orders(units, orders):
    """Units with their current orders set: (slot, Order, target slot or None, (x, y))."""
    units = jax.tree_util.tree_map(np.array, jax.device_get(units))
    for slot, order, target, xy in orders:
        units.orders[slot, 0], units.order_pos[slot, 0] = order, xy
        if target is not None:
            units.order_unit[slot, 0] = target
    return jax.tree_util.tree_map(jnp.asarray, units)


def scene(units_spec, camera=CAM):
    """A state of the map holding only the given units, and the shared compiled step.

    Args:
      units_spec: (slot, UnitType, Owner, (x, y), selected) per unit.
      camera: the camera centre.

    Returns:
      (step, state).
    """
    state = _template().replace(units=make_units(small_sim(MAP).game.num_slots, units_spec),
                                camera=jnp.array(camera, jnp.float32))
    return compiled(small_sim(MAP))[1], state


def set_unit(state, slot, **fields):
    """Sets per-unit fields of one slot (health=..., order=(Order, (x, y)))."""
    units = jax.tree_util.tree_map(np.array, jax.device_get(state.units))
    for name, value in fields.items():
        if name == "order":
            units.orders[slot, 0], units.order_pos[slot, 0] = value
        else:
            getattr(units, name)[slot] = value
    return state.replace(units=jax.tree_util.tree_map(jnp.asarray, units))


def act(step, state, call):
    """One agent step with a FunctionCall; returns (state, numpy timestep)."""
    state, ts = step(state, to_dense(call, small_sim(MAP).fmt.types), PARAMS)
    return state, jax.device_get(ts)


def no_op(step, state, steps=1):
    ts = None
    for _ in range(steps):
        state, ts = act(step, state, FUNCTIONS.no_op())
    return state, ts


def pos(state, slot):
    return np.asarray(state.units.pos[slot])


def selected_slots(state):
    units = jax.device_get(state.units)
    return set(np.flatnonzero(units.selected & units.alive).tolist())


def selected_pixels(ts):
    """(y, x) pixels of the `selected` screen layer that are set."""
    layer = ts.observation["feature_screen"][7]
    return set(zip(*np.nonzero(layer)))


def available(ts):
    return set(np.flatnonzero(ts.observation["available_actions_mask"]).tolist())


# Movement and orders -----------------------------------------------------------------

# Pixel (20, 11) is world (35.375, 28.375); the marine starts 5 to its left at
# (30.375, 28.375).
GOAL = pixel_centre(CAM, 20, 11)
START = (GOAL[0] - 5.0, GOAL[1])


def move_scene(marine_xy=START):
    step, state = scene([
        (0, UnitType.MARINE, Owner.SELF, marine_xy, True),
        (4, UnitType.ZERGLING, Owner.ENEMY, FAR, False),
    ])
    return step, set_unit(state, 4, order=(Order.HOLD, FAR))


@pytest.mark.slow
def test_a_run_time_loop_count_steps_as_that_step_mul_does():
    # The SC2-API server runs every `RequestStep.count` with one program (step_mul 8):
    # here 3 loops, on a map whose loops hold combat.
    map_name, loops = "DefeatRoaches", 3
    sim = small_sim(map_name)
    dynamic = jax.jit(lambda state, action, count: sim.step(state, action, PARAMS,
                                                            loops=count))
    fixed = simulator(map_name, sim.fmt, loops, 0, 1.0, 1.0, False, sim.use_slot_sizes)
    played = list(random_play(fixed, seed=loops, steps=6))
    state = played[0][0]
    for action, want_state, want_timestep in played[1:]:
        state, timestep = dynamic(state, action, np.int32(loops))
        assert_trees_equal((state, timestep), (want_state, want_timestep))


def test_pixel_centre_is_pysc2s_transform():
    # pixel = (world - camera) * 32/24 + 16: (35.375 - 32) * 4/3 + 16 = 20.5, and
    # (25 - 28.375) * 4/3 + 16 = 11.5, y flipped.
    assert GOAL == (35.375, 28.375)


def test_marine_moves_at_its_speed_and_the_order_finishes():
    step, state = move_scene()
    state, ts = act(step, state, FUNCTIONS.Move_screen("now", (20, 11)))
    # One step of 8 loops: 8 * 0.140625 = 1.125 along +x.
    np.testing.assert_allclose(pos(state, 0), (START[0] + 1.125, START[1]), atol=1e-5)
    assert int(state.units.orders[0, 0]) == Order.MOVE
    assert list(ts.observation["last_actions"][:1]) == [FUNCTIONS.Move_screen.id]
    assert int(ts.observation["action_result"][0]) == 0  # Success is not an error.
    assert ts.observation["feature_units"][0][FeatureUnit.order_length] == 1
    # 4 steps = 32 loops = 4.5: still 0.5 short, still moving.
    state, ts = no_op(step, state, 3)
    np.testing.assert_allclose(pos(state, 0), (START[0] + 4.5, START[1]), atol=1e-5)
    assert int(state.units.orders[0, 0]) == Order.MOVE
    # 5 / 0.140625 = 35.6: it arrives on loop 36 (within step 5) and the order ends.
    state, ts = no_op(step, state)
    np.testing.assert_allclose(pos(state, 0), GOAL, atol=1e-5)
    assert int(state.units.orders[0, 0]) == Order.NONE
    fu = ts.observation["feature_units"][0]
    fields = [FeatureUnit.unit_type, FeatureUnit.x, FeatureUnit.y, FeatureUnit.order_length]
    assert fu[fields].tolist() == [MARINE_ID, 20, 11, 0]
    # Idle: it stays.
    state, _ = no_op(step, state)
    np.testing.assert_allclose(pos(state, 0), GOAL, atol=1e-5)


def test_units_face_their_movement_and_their_target():
    # Facing is set once per agent step, from each unit's last turn in its loops.
    step, state = move_scene()
    state, _ = act(step, state, FUNCTIONS.Move_screen("now", (20, 4)))
    start = pos(state, 0)
    state, _ = no_op(step, state)
    dx, dy = pos(state, 0) - start
    assert dy > 0.5
    np.testing.assert_allclose(float(state.units.facing[0]), np.arctan2(dy, dx), atol=1e-6)
    assert float(state.units.facing[4]) == np.float32(DEFAULT_FACING)  # Held: never turned.
    # An idle marine turns to the zergling it shoots (in range, to its upper left).
    step, state = scene([
        (0, UnitType.MARINE, Owner.SELF, (30.0, 28.0), False),
        (4, UnitType.ZERGLING, Owner.ENEMY, (27.0, 31.0), False),
    ])
    state, _ = no_op(step, set_unit(state, 4, order=(Order.HOLD, (27.0, 31.0))))
    assert float(state.units.health[4]) < UNIT_DATA.max_health[UnitType.ZERGLING]
    np.testing.assert_allclose(float(state.units.facing[0]), 3 * np.pi / 4, atol=1e-6)


def test_queued_move_runs_after_the_first():
    step, state = move_scene()
    # A: pixel (17, 11) = (33.125, 28.375), 2.75 right of the start. B: pixel (17, 7) =
    # (33.125, 31.375), 3 above A.
    a, b = pixel_centre(CAM, 17, 11), pixel_centre(CAM, 17, 7)
    state, _ = act(step, state, FUNCTIONS.Move_screen("now", (17, 11)))
    state, _ = act(step, state, FUNCTIONS.Move_screen("queued", (17, 7)))
    # 16 loops: 16 * 0.140625 = 2.25 towards A; B waits in the queue.
    np.testing.assert_allclose(pos(state, 0), (START[0] + 2.25, START[1]), atol=1e-5)
    assert list(np.asarray(state.units.orders[0, :2])) == [Order.MOVE, Order.MOVE]
    np.testing.assert_allclose(state.units.order_pos[0, 1], b, atol=1e-5)
    # A is reached on loop ceil(2.75 / 0.140625) = 20; loops 21-24 go 4 * 0.140625 =
    # 0.5625 up towards B.
    state, _ = no_op(step, state)
    np.testing.assert_allclose(pos(state, 0), (a[0], a[1] + 0.5625), atol=1e-5)
    assert list(np.asarray(state.units.orders[0, :2])) == [Order.MOVE, Order.NONE]
    # B is 3 from A: 22 more loops (3 / 0.140625 = 21.3), done by loop 42 < 48.
    state, _ = no_op(step, state, 3)
    np.testing.assert_allclose(pos(state, 0), b, atol=1e-5)
    assert int(state.units.orders[0, 0]) == Order.NONE


def _queued_units(key, num_slots):
    """Units with random order queues: orders, targets, points and types."""
    k1, k2, k3 = jax.random.split(key, 3)
    units = Units.empty(num_slots)
    shape = units.orders.shape
    return units.replace(
        alive=jnp.ones(num_slots, bool),
        orders=jax.random.randint(k1, shape, 0, len(Order), jnp.int32),
        order_unit=jax.random.randint(k2, shape, -1, num_slots, jnp.int32),
        order_type=jax.random.randint(k2, shape, 0, 5, jnp.int32),
        order_pos=jax.random.uniform(k3, shape + (2,), maxval=64.0),
        pos=jax.random.uniform(k1, (num_slots, 2), maxval=64.0),
        target=jnp.arange(num_slots, dtype=jnp.int32))


@pytest.mark.parametrize("num_slots", [2, 28])
@pytest.mark.parametrize("batch", [None, 4, 64])
def test_pop_order_shifts_exactly_the_queues_of_units_done(num_slots, batch):
    """`pop_order` skips its shift when no order ends (a `cond` unbatched and for small
    batches, the shift always for large ones): the same as the shift every time, whether
    no unit, some or every unit of an environment is done."""
    envs = batch or 1
    keys = jax.random.split(jax.random.PRNGKey(num_slots), envs)
    units = jax.vmap(_queued_units, (0, None))(keys, num_slots)
    done = jax.random.bernoulli(jax.random.PRNGKey(7), 0.3, (envs, num_slots))
    done = done.at[0].set(False).at[-1].set(True) if envs > 1 else done
    plain, lazy = jax.vmap(dynamics._shift_orders), dynamics.pop_order
    if batch is None:
        one = lambda tree: jax.tree_util.tree_map(lambda x: x[0], tree)  # noqa: E731
        for d in (done, jnp.zeros_like(done)):
            assert_trees_equal(jax.jit(lazy)(*one((units, d))), one(plain(units, d)))
    else:
        assert_trees_equal(jax.jit(jax.vmap(lazy))(units, done), plain(units, done))
    np.testing.assert_array_equal(plain(units, done).orders[:, :, 0],
                                  np.where(done, units.orders[:, :, 1], units.orders[:, :, 0]))


def test_move_beyond_the_playable_area_stops_at_its_edge():
    # Minimap pixel (16, 31) is world (16.5 * 2, 64 - 31.5 * 2) = (33, 1), below the
    # playable area (10, 12)-(54, 44): the marine at (33, 14) goes to (33, 12), 2 away:
    # 1.125 in the first step, there on loop ceil(2 / 0.140625) = 15, and the order ends.
    step, state = move_scene(marine_xy=(33.0, 14.0))
    state, _ = act(step, state, FUNCTIONS.Move_minimap("now", (16, 31)))
    np.testing.assert_allclose(state.units.order_pos[0, 0], (33.0, 12.0))
    np.testing.assert_allclose(pos(state, 0), (33.0, 12.875), atol=1e-5)
    state, _ = no_op(step, state)
    np.testing.assert_allclose(pos(state, 0), (33.0, 12.0), atol=1e-5)
    assert int(state.units.orders[0, 0]) == Order.NONE


def test_queued_command_on_an_idle_unit_starts_at_once():
    step, state = move_scene()
    state, _ = act(step, state, FUNCTIONS.Move_screen("queued", (20, 11)))
    np.testing.assert_allclose(pos(state, 0), (START[0] + 1.125, START[1]), atol=1e-5)


def test_stop_clears_orders_and_the_unit_stays():
    step, state = move_scene()
    state, _ = act(step, state, FUNCTIONS.Move_screen("now", (20, 11)))
    state, _ = act(step, state, FUNCTIONS.Move_screen("queued", (17, 7)))
    state, ts = act(step, state, FUNCTIONS.Stop_quick("now"))
    # Stop acts before the step's loops: the marine stays where 16 loops took it.
    np.testing.assert_allclose(pos(state, 0), (START[0] + 2.25, START[1]), atol=1e-5)
    assert list(np.asarray(state.units.orders[0])) == [Order.NONE] * 4
    assert list(ts.observation["last_actions"][:1]) == [FUNCTIONS.Stop_quick.id]
    state, _ = no_op(step, state, 2)
    np.testing.assert_allclose(pos(state, 0), (START[0] + 2.25, START[1]), atol=1e-5)


def test_patrol_turns_at_both_ends():
    # Patrol target T = pixel (17, 11) = (33.125, 28.375); the marine starts 2.25 left
    # of it at P, so each leg takes exactly 2.25 / 0.140625 = 16 loops.
    t = pixel_centre(CAM, 17, 11)
    p = (t[0] - 2.25, t[1])
    step, state = move_scene(marine_xy=p)
    state, _ = act(step, state, FUNCTIONS.Patrol_screen("now", (17, 11)))
    state, _ = no_op(step, state)
    # Loop 16: at T, turned back towards P.
    np.testing.assert_allclose(pos(state, 0), t, atol=1e-5)
    assert int(state.units.orders[0, 0]) == Order.PATROL
    np.testing.assert_allclose(state.units.order_pos[0, 0], p, atol=1e-5)
    # Loop 24: 8 loops = 1.125 back towards P.
    state, _ = no_op(step, state)
    np.testing.assert_allclose(pos(state, 0), (t[0] - 1.125, t[1]), atol=1e-5)
    # Loop 32: at P, turned again towards T; loop 40: 1.125 towards T. Patrol never ends.
    state, _ = no_op(step, state)
    np.testing.assert_allclose(pos(state, 0), p, atol=1e-5)
    np.testing.assert_allclose(state.units.order_pos[0, 0], t, atol=1e-5)
    state, _ = no_op(step, state)
    np.testing.assert_allclose(pos(state, 0), (p[0] + 1.125, p[1]), atol=1e-5)
    assert int(state.units.orders[0, 0]) == Order.PATROL


# Selection ---------------------------------------------------------------------------

# With the camera at (32, 25): marines 0, 1, 2 at pixels (10, 16),
# (14, 16), (10, 22); an SCV (slot 6) at pixel (18, 22); an enemy zergling (slot 3) at
# pixel (24, 10) = (38.375, 29.125): 8.75 from marine 1 (within its sight 9, so it is
# drawn) and more than 5 + 0.75 from every marine (no one acquires anyone). Marine 5 is
# off screen at (46, 30) (x >= 32 + 12), 7.7 from zergling 3; zergling 4 far away at
# (52, 42) on hold.
M0, M1, M2 = (10, 16), (14, 16), (10, 22)
SCV_PX, ZERG_PX = (18, 22), (24, 10)


def selection_scene(selected=(False, False, False)):
    step, state = scene([
        (0, UnitType.MARINE, Owner.SELF, pixel_centre(CAM, *M0), selected[0]),
        (1, UnitType.MARINE, Owner.SELF, pixel_centre(CAM, *M1), selected[1]),
        (2, UnitType.MARINE, Owner.SELF, pixel_centre(CAM, *M2), selected[2]),
        (3, UnitType.ZERGLING, Owner.ENEMY, pixel_centre(CAM, *ZERG_PX), False),
        (4, UnitType.ZERGLING, Owner.ENEMY, FAR, False),
        (5, UnitType.MARINE, Owner.SELF, (46.0, 30.0), False),
    ])
    return step, set_unit(state, 4, order=(Order.HOLD, FAR))


def with_scv(state):
    return set_unit(state, 6, alive=True, type=UnitType.SCV, owner=Owner.SELF, tag=6,
                    pos=pixel_centre(CAM, *SCV_PX), health=45.0)


def yx(px):
    return (px[1], px[0])


def test_select_point_select_and_toggle():
    step, state = selection_scene()
    state, ts = act(step, state, FUNCTIONS.select_point("select", M0))
    assert selected_slots(state) == {0}
    assert selected_pixels(ts) == {yx(M0)}  # A marine's disc (r = 0.5 px) is one pixel.
    assert ts.observation["single_select"].tolist() == [[MARINE_ID, 1, 45, 0, 0, 0, 0]]
    assert not ts.observation["multi_select"].any()
    assert available(ts) == MARINE_CARD
    # Toggle adds an unselected unit...
    state, ts = act(step, state, FUNCTIONS.select_point("toggle", M1))
    assert selected_slots(state) == {0, 1}
    assert selected_pixels(ts) == {yx(M0), yx(M1)}
    assert not ts.observation["single_select"].any()
    assert ts.observation["multi_select"][:3].tolist() == [
        [MARINE_ID, 1, 45, 0, 0, 0, 0]] * 2 + [[0] * 7]
    assert available(ts) == MARINE_CARD | {5}
    # ... and removes a selected one.
    state, ts = act(step, state, FUNCTIONS.select_point("toggle", M0))
    assert selected_slots(state) == {1}
    assert selected_pixels(ts) == {yx(M1)}
    # Select replaces the selection.
    state, ts = act(step, state, FUNCTIONS.select_point("select", M2))
    assert selected_slots(state) == {2}
    # Toggling or adding where nothing is drawn (a shift-click on the ground) keeps it...
    for act_name in ("toggle", "add_all_type"):
        state, ts = act(step, state, FUNCTIONS.select_point(act_name, (2, 2)))
        assert selected_slots(state) == {2}
        assert selected_pixels(ts) == {yx(M2)}
    # ... a plain click there clears it: only UI functions are left.
    state, ts = act(step, state, FUNCTIONS.select_point("select", (2, 2)))
    assert selected_slots(state) == set()
    assert not ts.observation["feature_screen"][7].any()
    assert not ts.observation["single_select"].any()
    assert available(ts) == UI_ONLY


def test_select_point_enemy_alone_has_no_commands():
    step, state = selection_scene(selected=(True, True, False))
    state, ts = act(step, state, FUNCTIONS.select_point("select", ZERG_PX))
    assert selected_slots(state) == {3}
    assert selected_pixels(ts) == {yx(ZERG_PX)}
    assert ts.observation["single_select"].tolist() == [[ZERGLING_ID, 4, 35, 0, 0, 0, 0]]
    assert available(ts) == UI_ONLY


def test_select_point_all_type_and_add_all_type():
    step, state = selection_scene()
    state = with_scv(state)
    state, ts = act(step, state, FUNCTIONS.select_point("select", SCV_PX))
    assert selected_slots(state) == {6}
    assert ts.observation["single_select"].tolist() == [[SCV_ID, 1, 45, 0, 0, 0, 0]]
    # add_all_type: the SCV stays, and every marine on the screen joins (not slot 5,
    # which is off screen).
    state, ts = act(step, state, FUNCTIONS.select_point("add_all_type", M1))
    assert selected_slots(state) == {0, 1, 2, 6}
    assert selected_pixels(ts) == {yx(M0), yx(M1), yx(M2), yx(SCV_PX)}
    assert ts.observation["multi_select"][:5, 0].tolist() == [MARINE_ID] * 3 + [SCV_ID, 0]
    # select_all_type: only the marines on the screen.
    state, ts = act(step, state, FUNCTIONS.select_point("select_all_type", M2))
    assert selected_slots(state) == {0, 1, 2}
    assert selected_pixels(ts) == {yx(M0), yx(M1), yx(M2)}


def test_select_rect_with_and_without_add():
    step, state = selection_scene()
    # Pixels x 9-15, y 15-17 hold marines 0 and 1 (pixel centres 10.5 and 14.5, 16.5).
    state, ts = act(step, state, FUNCTIONS.select_rect("select", (9, 15), (15, 17)))
    assert selected_slots(state) == {0, 1}
    assert selected_pixels(ts) == {yx(M0), yx(M1)}
    # The corners may come in any order.
    state, ts = act(step, state, FUNCTIONS.select_rect("add", (11, 23), (9, 21)))
    assert selected_slots(state) == {0, 1, 2}
    assert ts.observation["multi_select"][:4, 0].tolist() == [MARINE_ID] * 3 + [0]
    # Without add, the new box replaces the selection.
    state, ts = act(step, state, FUNCTIONS.select_rect("select", (9, 21), (11, 23)))
    assert selected_slots(state) == {2}
    assert ts.observation["single_select"][0, 0] == MARINE_ID
    # A box over only an enemy selects no own unit: the selection is cleared.
    state, ts = act(step, state, FUNCTIONS.select_rect("select", (22, 8), (26, 12)))
    assert selected_slots(state) == set()
    assert available(ts) == UI_ONLY


def test_select_unit_and_select_army():
    # Marines 0, 1, 2 and the SCV (slot 6) selected: the multi-select panel lists them
    # in slot order, so select_unit's index 3 is the SCV.
    step, state = selection_scene(selected=(True, True, True))
    state = set_unit(with_scv(state), 6, selected=True)
    state, ts = act(step, state, FUNCTIONS.select_unit("deselect_all_type", 3))
    assert selected_slots(state) == {0, 1, 2}
    state = set_unit(state, 6, selected=True)
    state, ts = act(step, state, FUNCTIONS.select_unit("deselect", 1))
    assert selected_slots(state) == {0, 2, 6}
    assert ts.observation["multi_select"][:4, 0].tolist() == [MARINE_ID, MARINE_ID, SCV_ID, 0]
    state, ts = act(step, state, FUNCTIONS.select_unit("select_all_type", 0))
    assert selected_slots(state) == {0, 2}
    state, ts = act(step, state, FUNCTIONS.select_unit("select", 1))
    assert selected_slots(state) == {2}
    assert 5 not in available(ts)  # One unit: no multi-select panel.
    # select_army: every army unit, on screen or not (marine 5); the SCV is no army.
    state = set_unit(state, 6, selected=True)
    state, ts = act(step, state, FUNCTIONS.select_army("select"))
    assert selected_slots(state) == {0, 1, 2, 5}
    state, ts = act(step, state, FUNCTIONS.select_point("select", SCV_PX))
    state, ts = act(step, state, FUNCTIONS.select_army("add"))
    assert selected_slots(state) == {0, 1, 2, 5, 6}


def test_control_groups():
    step, state = selection_scene()

    def groups(ts):
        return ts.observation["control_groups"].tolist()

    state, ts = act(step, state, FUNCTIONS.select_point("select", M0))
    state, ts = act(step, state, FUNCTIONS.select_control_group("set", 1))
    assert groups(ts)[1] == [MARINE_ID, 1]
    assert [g for i, g in enumerate(groups(ts)) if i != 1] == [[0, 0]] * 9
    # append: marine 1 joins group 1.
    state, ts = act(step, state, FUNCTIONS.select_point("select", M1))
    state, ts = act(step, state, FUNCTIONS.select_control_group("append", 1))
    assert groups(ts)[1] == [MARINE_ID, 2]
    # set group 2 to marine 2, then recall group 1.
    state, ts = act(step, state, FUNCTIONS.select_point("select", M2))
    state, ts = act(step, state, FUNCTIONS.select_control_group("set", 2))
    assert groups(ts)[2] == [MARINE_ID, 1]
    state, ts = act(step, state, FUNCTIONS.select_control_group("recall", 1))
    assert selected_slots(state) == {0, 1}
    assert selected_pixels(ts) == {yx(M0), yx(M1)}
    # set (without steal) keeps other memberships: marine 0 is then in groups 1 and 3.
    state, ts = act(step, state, FUNCTIONS.select_point("select", M0))
    state, ts = act(step, state, FUNCTIONS.select_control_group("set", 3))
    assert [groups(ts)[g] for g in (1, 2, 3)] == [[MARINE_ID, 2], [MARINE_ID, 1],
                                                  [MARINE_ID, 1]]
    # set_and_steal: group 2 becomes {marine 1}; marine 1 leaves group 1, marine 2
    # leaves group 2.
    state, ts = act(step, state, FUNCTIONS.select_point("select", M1))
    state, ts = act(step, state, FUNCTIONS.select_control_group("set_and_steal", 2))
    assert [groups(ts)[g] for g in (1, 2, 3)] == [[MARINE_ID, 1], [MARINE_ID, 1],
                                                  [MARINE_ID, 1]]
    state, ts = act(step, state, FUNCTIONS.select_control_group("recall", 2))
    assert selected_slots(state) == {1}
    # append_and_steal: marine 0 joins group 2 and leaves groups 1 and 3.
    state, ts = act(step, state, FUNCTIONS.select_point("select", M0))
    state, ts = act(step, state, FUNCTIONS.select_control_group("append_and_steal", 2))
    assert [groups(ts)[g] for g in (1, 2, 3)] == [[0, 0], [MARINE_ID, 2], [0, 0]]
    state, ts = act(step, state, FUNCTIONS.select_point("select", M2))
    state, ts = act(step, state, FUNCTIONS.select_control_group("recall", 2))
    assert selected_slots(state) == {0, 1}
    assert ts.observation["multi_select"][:3, 0].tolist() == [MARINE_ID] * 2 + [0]
    # Recalling an empty group changes nothing.
    state, ts = act(step, state, FUNCTIONS.select_control_group("recall", 1))
    assert selected_slots(state) == {0, 1}


def test_control_group_members_that_die_leave_it():
    step, state = selection_scene(selected=(True, True, False))
    state, ts = act(step, state, FUNCTIONS.select_control_group("set", 4))
    assert ts.observation["control_groups"][4].tolist() == [MARINE_ID, 2]
    # Marine 1 at 5 HP with the zergling next to it (0.8 apart: gap 0.05 <= 0.1 range):
    # the zergling's first bite (5 damage, marine armour 0) kills it on loop 1.
    m1 = pixel_centre(CAM, *M1)
    state = set_unit(state, 1, health=5.0)
    state = set_unit(state, 3, pos=(m1[0] + 0.8, m1[1]))
    state, ts = no_op(step, state)
    assert not bool(state.units.alive[1])
    assert ts.observation["control_groups"][4].tolist() == [MARINE_ID, 1]
    assert selected_slots(state) == {0}


# Camera ------------------------------------------------------------------------------

def test_move_camera_follows_pysc2s_transforms_and_is_clamped():
    # The minimap (32 px) spans the 64-unit map: 2 units per pixel, y flipped, and a
    # pixel stands for its centre: pixel (16, 16) -> (16.5 * 2, 64 - 16.5 * 2) = (33, 31).
    step, state = selection_scene()
    state, ts = act(step, state, FUNCTIONS.move_camera((16, 16)))
    np.testing.assert_allclose(state.camera, (33.0, 31.0))
    # Pixel (0, 0) -> (1, 63), clamped to the camera bounds' corner (10, 44). A marine
    # at the centre of screen pixel (16, 16), (10.375, 43.625), is drawn there.
    corner = pixel_centre((10.0, 44.0), 16, 16)
    state = set_unit(state, 0, pos=corner)
    state, ts = act(step, state, FUNCTIONS.move_camera((0, 0)))
    np.testing.assert_allclose(state.camera, (10.0, 44.0))
    fu = ts.observation["feature_units"]
    assert fu[0][[0, 12, 13]].tolist() == [MARINE_ID, 16, 16]  # unit_type, x, y.
    assert ts.observation["feature_screen"][6][16, 16] == MARINE_ID
    assert ts.observation["feature_screen"][6].astype(bool).sum() == 1
    # The minimap camera layer: the view spans x in [-2, 22) and y in (32, 56]; minimap
    # column i is x = 2i + 1 and row j is y = 63 - 2j: columns 0-10 and rows 4-15.
    expected = np.zeros((32, 32), np.int32)
    expected[4:16, 0:11] = 1
    np.testing.assert_array_equal(ts.observation["feature_minimap"][3], expected)
    # Pixel (31, 31) -> (63, 1), clamped to (54, 8). A marine at screen pixel (15, 10),
    # (53.625, 12.125), inside the playable area.
    corner = pixel_centre((54.0, 8.0), 15, 10)
    assert corner == (53.625, 12.125)
    state = set_unit(state, 0, pos=corner)
    state, ts = act(step, state, FUNCTIONS.move_camera((31, 31)))
    np.testing.assert_allclose(state.camera, (54.0, 8.0))
    assert ts.observation["feature_units"][0][[0, 12, 13]].tolist() == [MARINE_ID, 15, 10]
    assert ts.observation["feature_screen"][6][10, 15] == MARINE_ID


# Availability ------------------------------------------------------------------------

def test_available_actions_follow_the_selection():
    step, state = selection_scene(selected=(True, True, True))
    state, ts = no_op(step, state)
    assert available(ts) == MARINE_CARD | {5}  # Several units: select_unit too.
    step, state = selection_scene(selected=(False, True, False))
    state, ts = no_op(step, state)
    assert available(ts) == MARINE_CARD
    step, state = selection_scene()
    state, ts = no_op(step, state)
    assert available(ts) == UI_ONLY
    # An idle SCV makes select_idle_worker available.
    state, ts = no_op(step, with_scv(state))
    assert available(ts) == UI_ONLY | {6}


def test_unavailable_action_raises_in_the_wrapper():
    env = make(MAP, seed=0, **SMALL_MAKE)
    ts = env.reset()
    # The map preselects its three marines.
    assert set(ts.observation["available_actions"].tolist()) == MARINE_CARD | {5}
    with pytest.raises(ValueError, match="477/Train_Marine_quick is not available"):
        env.step(FUNCTIONS.Train_Marine_quick("now"))
    # Clicking empty ground clears the selection; then Move is not available.
    ts = env.step(FUNCTIONS.select_point("select", (0, 0)))
    assert set(ts.observation["available_actions"].tolist()) == UI_ONLY
    with pytest.raises(ValueError, match="331/Move_screen is not available"):
        env.step(FUNCTIONS.Move_screen("now", (5, 5)))


def test_unavailable_action_is_a_reported_no_op_without_the_check():
    env = make(MAP, seed=0, ensure_available_actions=False, **SMALL_MAKE)
    env.reset()
    ts = env.step(FUNCTIONS.select_point("select", (0, 0)))
    marines = ts.observation["raw_units"][:3].copy()
    assert marines[:, FeatureUnit.unit_type].tolist() == [MARINE_ID] * 3
    ts = env.step(FUNCTIONS.Move_screen("now", (5, 5)))
    assert ts.observation["action_result"].tolist() == [ActionResult.NotSupported]
    assert ts.observation["last_actions"].tolist() == []
    # The marines took no order and did not move.
    assert ts.observation["raw_units"][:3, FeatureUnit.order_length].tolist() == [0, 0, 0]
    np.testing.assert_array_equal(ts.observation["raw_units"][:3], marines)
    # A later valid action reports no error.
    ts = env.step(FUNCTIONS.no_op())
    assert ts.observation["action_result"].tolist() == []


# Combat ------------------------------------------------------------------------------

def fight_scene(zergling_xy, marine_xy=(30.0, 28.0)):
    """Marine 0 (selected) and zergling 3 on hold; zergling 4 far away on hold."""
    step, state = scene([
        (0, UnitType.MARINE, Owner.SELF, marine_xy, True),
        (3, UnitType.ZERGLING, Owner.ENEMY, zergling_xy, False),
        (4, UnitType.ZERGLING, Owner.ENEMY, FAR, False),
    ], camera=CAM)
    state = set_unit(state, 3, order=(Order.HOLD, zergling_xy))
    return step, set_unit(state, 4, order=(Order.HOLD, (52.0, 42.0)))


def run_loops(units, seed, loops, until_dead=None):
    """Runs the jitted game loop; returns (units, [(loop, zergling 3 health) per change],
    the loop on which slot `until_dead` died or None)."""
    playable = small_sim(MAP).game.geometry.playable
    key = jax.random.PRNGKey(seed)
    changes, last, died_on = [], float(units.health[3]), None
    for loop in range(1, loops + 1):
        key, k = jax.random.split(key)
        units, events = _GAME_LOOP(units, k, playable)
        if float(units.health[3]) != last:
            last = float(units.health[3])
            changes.append((loop, last))
        if until_dead is not None and bool(events.died[until_dead]):
            died_on = loop
            break
    return units, changes, died_on


def test_marine_kills_a_zergling_in_six_shots_at_its_cooldown():
    # 35 HP / 6 damage (armour 0) -> 6 shots: 29, 23, 17, 11, 5, dead. Zergling 3
    # holds 4 away (gap 4 - 0.75 = 3.25 <= range 5), so the marine fires from where it
    # stands. A ready weapon fires on loop 1; each next shot comes when 13.7728 loops
    # plus a jitter of -1..+2 have passed, the fraction carried over: shot k on loop
    # 1 + ceil(13.7728 (k - 1) + jitters), so the sixth on loop 1 + ceil(68.864 + J),
    # J in [-5, 10]: loops 65..80. With the carry c in (-1, 0], each interval is
    # ceil(13.7728 + jitter + c): 12..16 loops.
    _, state = fight_scene((34.0, 28.0))
    state = set_unit(state, 0, order=(Order.ATTACK_UNIT, (34.0, 28.0)))
    units = set_unit(state, 0, order_unit=(3, -1, -1, -1)).units
    for seed in (7, 8, 9):
        after, changes, died_on = run_loops(units, seed, 100, until_dead=3)
        shots = [loop for loop, _ in changes]
        assert [h for _, h in changes] == [29.0, 23.0, 17.0, 11.0, 5.0, 0.0]
        assert shots[0] == 1 and died_on == shots[-1]
        gaps = np.diff(shots)
        assert all(12 <= g <= 16 for g in gaps), gaps
        assert 65 <= shots[-1] <= 80, shots
        assert not bool(after.alive[3])
        # The zergling is removed: the next loop ends the attack-unit order. The marine
        # never moved.
        after, _, _ = run_loops(after, seed, 1)
        assert int(after.orders[0, 0]) == Order.NONE
        np.testing.assert_allclose(after.pos[0], (30.0, 28.0))


def test_weapon_cooldown_and_jitter():
    # After a ready weapon fires (loop 1), the next shot waits ceil(13.7728 + jitter)
    # loops: 13, 14, 15 or 16 for jitter -1, 0, 1, 2 (never 12: a weapon cannot fire
    # before its cooldown has passed). 32 independent first intervals show all four.
    _, state = fight_scene((34.0, 28.0))
    units = set_unit(state, 3, health=1e6).units
    first = set()
    for seed in range(32):
        _, changes, _ = run_loops(units, seed, 17)
        assert changes[0][0] == 1
        first.add(changes[1][0] - changes[0][0])
    assert first == {13, 14, 15, 16}
    # Over many shots the mean interval is 13.7728 + 0.5 (the mean jitter) = 14.27.
    _, changes, _ = run_loops(units, 100, 720)
    gaps = np.diff([loop for loop, _ in changes])
    assert set(gaps.tolist()) <= {12, 13, 14, 15, 16}
    assert abs(gaps.mean() - 14.27) < 0.4, gaps.mean()


def test_attack_screen_on_an_enemy_is_attack_unit():
    # Zergling 3 at pixel (24, 10) = (38.375, 29.125); the marine at (30, 28): 8.45 away,
    # out of range (gap 7.70 > 5) and out of acquisition. Clicking the zergling with
    # Attack gives an attack-unit order: the marine closes to range, then fires.
    zerg = pixel_centre(CAM, *ZERG_PX)
    step, state = fight_scene(zerg)
    state, ts = act(step, state, FUNCTIONS.Attack_screen("now", ZERG_PX))
    assert int(state.units.orders[0, 0]) == Order.ATTACK_UNIT
    assert int(state.units.order_unit[0, 0]) == 3
    # It must cover 7.70 - 5 = 2.70 = 19.2 loops of walking: after 8 loops it has moved
    # 1.125 straight at the zergling and not yet fired.
    d0 = np.hypot(zerg[0] - 30.0, zerg[1] - 28.0)
    d1 = np.hypot(*(np.asarray(zerg) - pos(state, 0)))
    np.testing.assert_allclose(d0 - d1, 1.125, atol=1e-4)
    assert float(state.units.health[3]) == 35.0
    state, ts = no_op(step, state, 2)
    # By loop 24 it stands in range (gap <= 5, 1e-3 of slack) and has fired once.
    gap = np.hypot(*(np.asarray(zerg) - pos(state, 0))) - 0.75
    assert 4.99 <= gap <= 5.0
    assert float(state.units.health[3]) == 29.0
    # Five more shots, the last by loop 21 + 5 * 15.77 < 101 (step 13).
    state, ts = no_op(step, state, 10)
    assert not bool(state.units.alive[3])
    assert int(state.units.orders[0, 0]) == Order.NONE
    assert int(ts.observation["score_cumulative"][0]) == 1  # +1 for the zergling.


def test_smart_attacks_an_enemy_and_moves_on_the_ground():
    # Smart (right-click) on the zergling's pixel is an attack-unit order; on empty
    # ground, pixel (20, 11) = (35.375, 28.375), a move.
    zerg = pixel_centre(CAM, *ZERG_PX)
    step, state = fight_scene(zerg)
    state, _ = act(step, state, FUNCTIONS.Smart_screen("now", ZERG_PX))
    assert int(state.units.orders[0, 0]) == Order.ATTACK_UNIT
    assert int(state.units.order_unit[0, 0]) == 3
    state, ts = act(step, state, FUNCTIONS.Smart_screen("now", (20, 11)))
    assert int(state.units.orders[0, 0]) == Order.MOVE
    np.testing.assert_allclose(state.units.order_pos[0, 0], GOAL)
    assert list(ts.observation["last_actions"][:1]) == [FUNCTIONS.Smart_screen.id]


def test_attack_move_fights_on_the_way_but_move_does_not():
    # The goal is given on the minimap: pixel (20, 18) is (20.5 * 2, 64 - 18.5 * 2) =
    # (41, 27). The marine walks from (20, 27) along y = 27, passing 1.0 from zergling 3,
    # which holds at (30, 28) (gap 0.25: no collision, beyond the zergling's 0.1 reach).
    step, state = fight_scene((30.0, 28.0), marine_xy=(20.0, 27.0))
    state, _ = act(step, state, FUNCTIONS.Move_minimap("now", (20, 18)))
    np.testing.assert_allclose(state.units.order_pos[0, 0], (41.0, 27.0))
    state, ts = no_op(step, state, 20)
    # A move order ignores enemies: the zergling is untouched, the marine arrived
    # (21 units at 1.125 per step: 19 steps) and went round the zergling.
    assert float(state.units.health[3]) == 35.0
    np.testing.assert_allclose(pos(state, 0), (41.0, 27.0), atol=1e-3)
    # Attack-move: it stops to kill the zergling (35 HP: 6 shots, about 70 loops), then
    # goes on to the goal.
    step, state = fight_scene((30.0, 28.0), marine_xy=(20.0, 27.0))
    state, ts = act(step, state, FUNCTIONS.Attack_minimap("now", (20, 18)))
    assert int(state.units.orders[0, 0]) == Order.ATTACK_MOVE
    rewards = [float(ts.reward)]
    for _ in range(40):
        state, ts = no_op(step, state)
        rewards.append(float(ts.reward))
    assert not bool(state.units.alive[3])
    assert sum(rewards) == 1.0
    np.testing.assert_allclose(pos(state, 0), (41.0, 27.0), atol=1e-3)
    assert int(state.units.orders[0, 0]) == Order.NONE


def test_hold_position_fires_but_never_chases():
    # Zergling 3 starts 4 from the marine (gap 3.25, in range) and runs away with a move
    # order (0.1846 per loop, faster than the marine). Both marines fire on loop 1
    # (35 -> 29) and again only after ~14 loops. The idle marine chases the zergling
    # (it stays within sight 9); the holding marine stays put.
    results = {}
    for hold in (False, True):
        step, state = fight_scene((34.0, 28.0))
        state = set_unit(state, 3, order=(Order.MOVE, (50.0, 28.0)))
        call = FUNCTIONS.HoldPosition_quick("now") if hold else FUNCTIONS.no_op()
        state, ts = act(step, state, call)
        assert float(state.units.health[3]) == 29.0
        state, _ = no_op(step, state, 2)
        results[hold] = (pos(state, 0), int(state.units.orders[0, 0]))
    held_pos, held_order = results[True]
    np.testing.assert_allclose(held_pos, (30.0, 28.0))
    assert held_order == Order.HOLD
    idle_pos, idle_order = results[False]
    assert idle_pos[0] > 31.0 and idle_order == Order.NONE


# Mini-game rewards -------------------------------------------------------------------

def script_state(map_name, units_spec):
    """A state holding another map's units (its script reads only units, minerals,
    score and key, so the template state carries them)."""
    game, on_loop, on_step = script(map_name)
    state = _template().replace(units=make_units(game.num_slots, units_spec))
    return game, on_loop, on_step, state


def test_move_to_beacon_reward_and_beacon_jump():
    # +1 when the marine's centre is within 1.25 of the beacon's, checked every loop;
    # the beacon then jumps to region 3, (23.5, 21.5)-(42.5, 34.5), outside the circle
    # r = 4 at (33, 28), at least 5 from the marine.
    marine = (30.0, 28.0)
    for seed in range(8):
        game, on_loop, _, state = script_state(BEACON_MAP, [
            (0, UnitType.MARINE, Owner.SELF, marine, True),
            (1, UnitType.BEACON, Owner.NEUTRAL, (30.0, 29.249), False),
        ])
        state = on_loop(state.replace(key=jax.random.PRNGKey(seed)), LoopEvents.none(2))
        assert int(state.score) == 1
        beacon = pos(state, 1)
        assert np.hypot(*(beacon - marine)) >= 5.0
        assert 23.5 <= beacon[0] <= 42.5 and 21.5 <= beacon[1] <= 34.5
        assert np.hypot(beacon[0] - 33.0, beacon[1] - 28.0) >= 4.0
        # The next loop the beacon is far: no more reward.
        assert int(on_loop(state, LoopEvents.none(2)).score) == 1
    # 1.251 away: nothing happens.
    _, on_loop, _, state = script_state(BEACON_MAP, [
        (0, UnitType.MARINE, Owner.SELF, marine, True),
        (1, UnitType.BEACON, Owner.NEUTRAL, (31.251, 28.0), False),
    ])
    after = on_loop(state, LoopEvents.none(2))
    assert int(after.score) == 0
    np.testing.assert_array_equal(after.units.pos, state.units.pos)


def test_collect_mineral_shards_pickup_and_respawn():
    # A marine picks up a shard its centre is within 0.375 + 0.375 = 0.75 of: +100
    # minerals, and the score (minerals / 100) rises by 1 per shard. Marine 0 is 0.74
    # from shard 2 and 0.76 from shard 3; marine 1 is 0.5 from shard 4.
    game, on_loop, on_step, state = script_state(SHARDS_MAP, [
        (0, UnitType.MARINE, Owner.SELF, (30.0, 28.0), False),
        (1, UnitType.MARINE, Owner.SELF, (40.0, 24.0), False),
        (2, UnitType.MINERAL_SHARD, Owner.NEUTRAL, (30.74, 28.0), False),
        (3, UnitType.MINERAL_SHARD, Owner.NEUTRAL, (30.0, 27.24), False),
        (4, UnitType.MINERAL_SHARD, Owner.NEUTRAL, (40.0, 24.5), False),
    ])
    events = LoopEvents.none(game.num_slots)
    state = on_loop(state, events)
    assert np.asarray(state.units.alive[2:5]).tolist() == [False, True, False]
    assert int(state.minerals) == 200 and int(state.score) == 2
    # A shard remains: no respawn at the end of the step.
    assert np.asarray(on_step(state).units.alive[2:22]).sum() == 1
    # Marine 0 steps to 0.75 from shard 3: +1; none is left, and at the end of the step
    # 20 new shards appear in region 3, (23, 21)-(43, 35), each at least 2 from both
    # marines.
    state = set_unit(state, 0, pos=(30.0, 27.99))
    state = on_loop(state, events)
    assert int(state.minerals) == 300 and int(state.score) == 3
    assert not np.asarray(state.units.alive[2:22]).any()
    units = jax.device_get(on_step(state).units)
    assert units.alive[2:22].all() and (units.type[2:22] == UnitType.MINERAL_SHARD).all()
    shards = units.pos[2:22]
    d = np.linalg.norm(shards[:, None, :] - units.pos[None, :2], axis=-1)
    assert d.min() >= 2.0
    assert ((shards >= (23.0, 21.0)) & (shards <= (43.0, 35.0))).all()


def test_find_and_defeat_zerglings_placements_follow_the_script():
    # The script's rules, in every one of 512 placements: zergling 1 at U(8, 9) from the
    # centre, zergling 2 in the ring 7.5-9.5, the rest in (11, 13)-(53, 43) outside
    # r = 10.5; respawns in region 1, >= 9 from every marine; always >= 5 apart. The
    # ring is uniform by area: 16/34 of it lies inside r = 8.5.
    from sc2jax.environment.engine.minigames import find_and_defeat_zerglings as fdz

    keys = jax.random.split(jax.random.PRNGKey(5), 512)
    first = np.asarray(jax.jit(jax.vmap(fdz.initial_zerglings))(keys))
    marines = jnp.asarray([[30.0, 28.0], [34.0, 28.0], [20.0, 40.0]])
    alive = jnp.asarray([True, True, False])  # A dead marine keeps nothing away.
    again = np.asarray(jax.jit(jax.vmap(
        lambda k: fdz.respawned_zerglings(k, marines, alive)))(keys))
    r = np.linalg.norm(first - np.asarray(fdz.CENTER), axis=-1)
    assert ((r[:, 0] >= 8.0) & (r[:, 0] <= 9.0)).all()
    assert ((r[:, 1] >= 7.5) & (r[:, 1] <= 9.5)).all()
    assert abs((r[:, 1] < 8.5).mean() - 16 / 34) < 0.07
    assert (r[:, 2:] >= 10.5).all()
    assert ((first[:, 2:] >= (11.0, 13.0)) & (first[:, 2:] <= (53.0, 43.0))).all()
    assert ((again >= (10.0, 12.0)) & (again <= (54.0, 44.0))).all()
    to_marines = np.linalg.norm(again[:, :, None] - np.asarray(marines)[:2], axis=-1)
    assert to_marines.min() >= 9.0
    assert (np.linalg.norm(again - np.asarray(marines)[2], axis=-1) < 9.0).any()
    for placed in (first, again):
        d = np.linalg.norm(placed[:, :, None] - placed[:, None], axis=-1)
        assert (d + 99 * np.eye(25) >= 5.0).all()


def test_find_and_defeat_zerglings_kill_and_loss():
    # Kill: a 6-HP zergling 4 from an idle marine (gap 3.25 <= acquisition 5): the
    # marine's first shot on loop 1 kills it. +1, and it is removed.
    step, state = fight_scene((34.0, 28.0))
    state = set_unit(state, 3, health=6.0)
    state, ts = no_op(step, state)
    assert float(ts.reward) == 1.0
    assert not bool(state.units.alive[3])
    # Zergling 4 is hidden by fog, and zergling 3 is gone.
    assert ZERGLING_ID not in ts.observation["raw_units"][:, 0].tolist()
    assert int(ts.step_type) == dm_env.StepType.MID
    # Loss: marine 1 at 5 HP, a zergling 0.8 from it (gap 0.05 <= 0.1): its first bite
    # kills the marine (-1). The marine shoots back once (35 -> 29). Marine 0 lives on.
    step, state = scene([
        (0, UnitType.MARINE, Owner.SELF, (20.0, 20.0), False),
        (1, UnitType.MARINE, Owner.SELF, (40.0, 30.0), False),
        (3, UnitType.ZERGLING, Owner.ENEMY, (40.8, 30.0), False),
    ])
    state = set_unit(state, 1, health=5.0)
    state, ts = no_op(step, state)
    assert float(ts.reward) == -1.0
    assert not bool(state.units.alive[1])
    assert float(state.units.health[3]) == 29.0
    assert int(ts.step_type) == dm_env.StepType.MID and float(ts.discount) == 1.0
    # The last marine's death ends the episode: LAST, discount 0.
    step, state = scene([
        (1, UnitType.MARINE, Owner.SELF, (40.0, 30.0), False),
        (3, UnitType.ZERGLING, Owner.ENEMY, (40.8, 30.0), False),
    ])
    state = set_unit(state, 1, health=5.0)
    state, ts = no_op(step, state)
    assert float(ts.reward) == -1.0
    assert int(ts.step_type) == dm_env.StepType.LAST and float(ts.discount) == 0.0


def test_scenes_reuse_the_compiled_step():
    # A scene has exactly the avals of a reset state, so stepping it never recompiles.
    reset, step = compiled(small_sim(MAP))
    state, _ = reset(jax.random.PRNGKey(1), PARAMS)
    act(step, state, FUNCTIONS.no_op())
    size = step._cache_size()
    _, state = move_scene()
    act(step, set_unit(state, 0, health=1.0, order=(Order.MOVE, (40.0, 30.0))),
        FUNCTIONS.no_op())
    assert step._cache_size() == size


@pytest.mark.parametrize("map_name", [BEACON_MAP, SHARDS_MAP])
def test_collisions_among_the_collider_slots_are_all_the_collisions(map_name):
    # Maps that declare `collider_slots` never put a colliding unit beyond them...
    game = get_map(map_name)
    c = game.collider_slots
    units, _, _ = jax.jit(jax.vmap(game.init))(jax.random.split(jax.random.PRNGKey(0), 16))
    beyond = np.asarray(colliding(jax.tree.map(lambda col: col[units.type[:, c:]], UNIT_DATA)))
    assert not (beyond & np.asarray(units.alive[:, c:])).any()
    # ...so resolving collisions among them alone moves units exactly as resolving all
    # pairs does: here every unit is stacked at one point, shards and beacon included.
    one = jax.tree.map(lambda x: x[0], units)
    one = one.replace(pos=jnp.full_like(one.pos, 30.0).at[:, 0].add(jnp.arange(game.num_slots)
                                                                   * 1e-3))
    key, playable = jax.random.PRNGKey(1), game.geometry.playable
    run = functools.partial(game_loop, key=key, playable=playable, combat=False)
    full, _ = run(one)
    cut, _ = run(one, colliders=c)
    np.testing.assert_array_equal(cut.pos, full.pos)
    if c > 1:  # The stacked units were pushed apart.
        assert not np.array_equal(full.pos, one.pos)


@pytest.mark.parametrize("n", [9, 20, 28])
def test_collision_pushes_on_padded_rows_are_the_unpadded_pushes(n):
    # `pair_width` pads the pairs' rows with units that do not collide: the same pushes,
    # bit for bit, and a real padding at these counts.
    assert dynamics.pair_width(n) > n
    rng = np.random.default_rng(n)
    types = np.where(rng.random(n) < 0.3, int(UnitType.MARINE), int(UnitType.ZERGLING))
    data = jax.tree.map(lambda col: jnp.asarray(col)[types], UNIT_DATA)
    pos = jnp.asarray(rng.uniform(0.0, 3.0, (n, 2)), jnp.float32)
    pos = pos.at[1].set(pos[0])  # Two coincident units separate along their tie.
    pos = pos.at[2].set(jnp.array([0.1, 0.2]))  # Over the padding, which sits at (0, 0).
    alive = jnp.asarray(rng.random(n) < 0.9).at[2].set(True)
    # A fresh function for each trace (jit caches traces by function).
    push = lambda: jax.jit(lambda *a: dynamics._resolve_collisions(*a))(pos, alive, data)  # noqa: E731
    padded = push()
    with mock.patch.object(dynamics, "pair_width", lambda n: n):
        unpadded = push()
    np.testing.assert_array_equal(padded, unpadded)
    assert not np.array_equal(padded, pos)


@pytest.mark.parametrize("eyes", [64, 768])
def test_sight_grid_sees_exactly_the_pixels_within_sight(eyes):
    # Both of sight_grid's ways (unrolled up to 64 eyes, row intervals beyond) against
    # the distance test in numpy, on a melee map's cells, a minimap and a screen, with
    # units on and off the grid and on half-cell points (where rounding decides).
    rng = np.random.default_rng(eyes)
    seeing = np.flatnonzero(UNIT_DATA.sight > 0)
    w, h = 176, 184
    ppu = 64 / 24
    centre = np.float32([40.3, 151.7])
    grids = [(np.arange(w) + 0.5, h - 0.5 - np.arange(h), 1.0),
             ((np.arange(64) + 0.5) * 2.875, h - (np.arange(64) + 0.5) * 2.875, 2.875),
             (centre[0] + (np.arange(64) + 0.5 - 32) / ppu,
              centre[1] - (np.arange(64) + 0.5 - 32) / ppu, 1 / ppu)]
    for halves in (False, True):
        pos = rng.uniform(-5.0, 190.0, (eyes, 2)).astype(np.float32)
        pos[:8] = centre + rng.uniform(-12.0, 12.0, (8, 2))
        pos = np.round(pos * 2) / 2 if halves else pos
        units = Units.empty(eyes).replace(
            alive=jnp.asarray(rng.random(eyes) < 0.25),
            owner=jnp.asarray(rng.choice([Owner.SELF, Owner.ENEMY], eyes)),
            type=jnp.asarray(rng.choice(seeing, eyes)), pos=jnp.asarray(pos, jnp.float32))
        looks = np.asarray(units.alive & (units.owner == Owner.SELF))
        sight = UNIT_DATA.sight[np.asarray(units.type)].astype(np.float32)
        for xs, ys, spacing in grids:
            xs, ys = xs.astype(np.float32), ys.astype(np.float32)
            dx2 = (xs[None, None, :] - pos[:, None, None, 0]) ** 2
            dy2 = (ys[None, :, None] - pos[:, None, None, 1]) ** 2
            want = ((dy2 + dx2 <= (sight * sight)[:, None, None]) & looks[:, None, None]
                    ).any(0)
            got = jax.jit(sight_grid, static_argnums=3)(units, jnp.asarray(xs),
                                                        jnp.asarray(ys), spacing)
            np.testing.assert_array_equal(got, want)
            assert want.any() and not want.all()


def test_fog_looks_through_the_own_slots_alone():
    # FindAndDefeatZerglings declares `own_slots`: the player's units never leave them,
    # through play and a zergling respawn...
    sim = small_sim(MAP)
    own = sim.game.own_slots
    reset, step = compiled(sim)
    state, ts = reset(jax.random.PRNGKey(2), PARAMS)
    act = jax.jit(functools.partial(random_action, types=sim.fmt.types))
    key = jax.random.PRNGKey(3)
    states = [state]
    for i in range(12):
        if i == 6:  # Every zergling dead: the map respawns them at the next step.
            state = state.replace(units=state.units.replace(
                alive=state.units.alive.at[own:].set(False)))
        key, k = jax.random.split(key)
        state, ts = step(state, act(k, ts.observation["available_actions_mask"]), PARAMS)
        states.append(state)
    assert bool(states[7].units.alive[own:].any())  # The respawn happened.
    w, h = sim.game.geometry.size
    xs = jnp.arange(w, dtype=jnp.float32) + 0.5
    ys = h - 1 - jnp.arange(h, dtype=jnp.float32) + 0.5
    for s in states:
        units = s.units
        assert not np.asarray(units.alive[own:] & (units.owner[own:] == Owner.SELF)).any()
        # ...so looking through them alone sees exactly what looking through all does,
        # here with every enemy made the player's: the full grid then sees more.
        np.testing.assert_array_equal(sight_grid(units, xs, ys, 1.0, own),
                                      sight_grid(units, xs, ys, 1.0))
        mine = units.replace(owner=jnp.full_like(units.owner, Owner.SELF))
        assert bool((sight_grid(mine, xs, ys, 1.0) & ~sight_grid(mine, xs, ys, 1.0, own)).any())
