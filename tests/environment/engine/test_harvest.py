"""Exact harvesting scenes: the gather, mine, return and deposit cycle (`harvest`).

SCV: radius 0.375, speed 2.8125 / 16 = 0.17578 units per loop. Command Center radius
2.75; MineralField radius 1.125, 1800 minerals. A worker touches a unit within 0.1
(edge to edge), mines for 2.786 game seconds = 44.576 loops (done on the 45th), pauses
8 loops, and carries 5 minerals.
"""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment import FUNCTIONS
from sc2jax.environment.engine.availability import available_actions
from sc2jax.environment.engine.rules import commands
from sc2jax.environment.engine.rules.dynamics import game_loop
from sc2jax.environment.engine.rules.harvest import (
    DEPOT_SLOTS,
    LEAVE_LOOPS,
    MINING_LOOPS,
    MULE_MINING_LOOPS,
    REACH,
    nearest_depot,
)
from sc2jax.environment.engine.rules.state import Order, Owner
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType

from .test_mechanics import make_units, with_orders

PLAYABLE = (10.0, 10.0, 54.0, 54.0)
_LOOP = jax.jit(functools.partial(game_loop, playable=PLAYABLE, workers=True))
SPEED = 2.8125 / 16
CC, FIELD = (30.0, 28.0), (36.0, 28.0)
R_CC, R_FIELD, R_SCV = 2.75, 1.125, 0.375


def scene(scv_xs, contents=1800.0):
    """A Command Center (slot 0), a mineral field (slot 1), and SCVs (slots 2...) on the
    line between them, each ordered to gather from the field."""
    spec = [(0, UnitType.COMMAND_CENTER, Owner.SELF, CC, False),
            (1, UnitType.MINERAL_FIELD, Owner.NEUTRAL, FIELD, False)]
    spec += [(2 + i, UnitType.SCV, Owner.SELF, (x, 28.0), False) for i, x in enumerate(scv_xs)]
    units = with_orders(make_units(8, spec),
                        [(2 + i, Order.GATHER, 1, FIELD) for i in range(len(scv_xs))])
    return units.replace(contents=units.contents.at[1].set(contents))


def run(units, loops):
    """Runs `loops` loops; returns (units, minerals delivered per loop)."""
    key = jax.random.PRNGKey(0)
    delivered = []
    for _ in range(loops):
        key, k = jax.random.split(key)
        units, events = _LOOP(units, k)
        delivered.append(float(events.minerals[0]))  # The player's.
    return units, np.array(delivered)


def test_one_trip_delivers_five_minerals_after_walk_mine_and_walk_back():
    # The SCV starts touching the Command Center (gap 0.05). It walks to the field (gap
    # 1.325 -> within 0.1: ceil(1.225 / 0.17578) = 7 loops) and starts mining on the
    # loop it arrives, finishes 45 loops later, pauses 8 loops, and walks back (it
    # stopped 0.099 from the field, 1.276 from the Command Center: 7 loops): the deposit
    # is on loop 67.
    start = CC[0] + R_CC + R_SCV + 0.05
    gap_out = FIELD[0] - R_FIELD - R_SCV - start
    walk_out = math.ceil((gap_out - REACH) / SPEED)
    stop = FIELD[0] - R_FIELD - R_SCV - (REACH - 1e-3)
    walk_back = math.ceil((stop - (CC[0] + R_CC + R_SCV) - REACH) / SPEED)
    mine, pause = math.ceil(MINING_LOOPS), int(LEAVE_LOOPS)
    assert (walk_out, mine, pause, walk_back) == (7, 45, 8, 7)
    units = scene([start])
    units, delivered = run(units, walk_out + mine + pause + walk_back + 2)
    (trips,) = np.nonzero(delivered)
    assert trips.tolist() == [walk_out + mine + pause + walk_back - 1]  # Loop 67.
    assert delivered[trips[0]] == 5.0
    assert float(units.contents[1]) == 1795.0
    # It heads back to the same field, empty-handed.
    assert int(units.orders[2, 0]) == Order.GATHER and int(units.order_unit[2, 0]) == 1
    assert float(units.cargo[2]) == 0.0 and int(units.home[2]) == 1


def test_a_field_is_mined_by_one_worker_at_a_time():
    # Two SCVs touch the field at once: slot 2 starts mining on loop 1 and finishes 45
    # loops later (loop 46); slot 3 waits beside it and starts on that loop (both keep
    # their places: harvesting workers pass through each other).
    x = FIELD[0] - R_FIELD - R_SCV - 0.05
    units, _ = run(scene([x, x]), 1)
    assert float(units.work[2]) == np.float32(MINING_LOOPS) and float(units.work[3]) == 0.0
    units, _ = run(units, 44)
    assert float(units.work[3]) == 0.0 and float(units.cargo[2]) == 0.0
    units, _ = run(units, 1)
    assert int(units.orders[2, 0]) == Order.RETURN and float(units.cargo[2]) == 5.0
    assert int(units.order_unit[2, 0]) == 0  # The nearest Command Center.
    assert float(units.work[3]) > 0  # Slot 3 took the free field.
    np.testing.assert_allclose(units.pos[3], (x, 28.0))


def test_a_mined_out_field_disappears_and_its_workers_go_idle():
    x = FIELD[0] - R_FIELD - R_SCV - 0.05
    units, delivered = run(scene([x], contents=3.0), 80)
    # The last 3 minerals are taken and delivered; the field is gone; the SCV, back at
    # the Command Center with nowhere to return to, is idle.
    assert delivered.sum() == 3.0
    assert not bool(units.alive[1])
    assert int(units.orders[2, 0]) == Order.NONE and float(units.cargo[2]) == 0.0
    assert UNIT_DATA.contents[UnitType.MINERAL_FIELD] == 1800.0


def test_only_workers_take_harvest_orders_and_return_cargo_needs_cargo():
    units = make_units(8, [(0, UnitType.COMMAND_CENTER, Owner.SELF, CC, False),
                           (1, UnitType.MINERAL_FIELD, Owner.NEUTRAL, FIELD, False),
                           (2, UnitType.SCV, Owner.SELF, (33.5, 28.0), True),
                           (3, UnitType.MARINE, Owner.SELF, (33.5, 30.0), True)])
    gathered, ok = commands.issue(units, Order.GATHER, 0, jnp.array(FIELD), 1)
    assert bool(ok)
    assert np.asarray(gathered.orders[2:4, 0]).tolist() == [Order.GATHER, Order.NONE]
    assert int(gathered.order_unit[2, 0]) == 1
    available = np.asarray(available_actions(units))
    assert available[FUNCTIONS.Harvest_Gather_screen.id]
    assert not available[FUNCTIONS.Harvest_Return_quick.id]
    carrying = units.replace(cargo=units.cargo.at[2].set(5.0))
    assert np.asarray(available_actions(carrying))[FUNCTIONS.Harvest_Return_quick.id]
    # A return order without a target heads for the nearest Command Center and deposits.
    returning, _ = commands.issue(carrying, Order.RETURN, 0, jnp.array(CC))
    assert int(returning.order_unit[2, 0]) == -1
    after, delivered = run(returning, 10)
    assert delivered.sum() == 5.0 and float(after.cargo[2]) == 0.0
    # With no home field it then goes idle.
    assert int(after.orders[2, 0]) == Order.NONE


def _brute_nearest_depot(units):
    """nearest_depot by hand: every own complete Command Center, the lowest slot on a tie."""
    units = jax.device_get(units)
    depots = np.nonzero(units.complete & (units.type == UnitType.COMMAND_CENTER))[0]
    nearest = []
    for i in range(len(units.pos)):
        mine = [j for j in depots if units.owner[j] == units.owner[i]]
        d = [np.hypot(*(units.pos[i] - units.pos[j])) for j in mine]
        nearest.append(mine[int(np.argmin(d))] if mine else -1)
    return np.array(nearest)


def depot_scene(num_ccs):
    """`num_ccs` Command Centers of the player in a row (one more, incomplete, and one of
    the enemy's), with SCVs and a mineral field scattered between them."""
    xs = [14.0 + 7.0 * k for k in range(num_ccs)]
    spec = [(2 * k, UnitType.COMMAND_CENTER, Owner.SELF, (x, 20.0), False)
            for k, x in enumerate(xs)]
    spec += [(15, UnitType.COMMAND_CENTER, Owner.SELF, (40.0, 40.0), False),
             (16, UnitType.COMMAND_CENTER, Owner.ENEMY, (12.0, 30.0), False),
             (17, UnitType.MINERAL_FIELD, Owner.NEUTRAL, (30.0, 33.0), False)]
    # Slot 1 is as far from the first two Command Centers: the tie goes to slot 0.
    spec += [(1, UnitType.SCV, Owner.SELF, (17.5, 25.0), False)]
    spec += [(18 + k, UnitType.SCV, Owner.SELF, (11.0 + 3.7 * k, 27.0 - 1.3 * k), False)
             for k in range(10)]
    units = make_units(32, spec)
    return units.replace(progress=units.progress.at[15].set(0.0))  # Still building.


def test_nearest_depot_measures_to_every_command_center_also_beyond_those_it_checks_first():
    few, many = depot_scene(2), depot_scene(DEPOT_SLOTS + 3)
    for units in (few, many):
        nearest = np.asarray(jax.jit(nearest_depot)(units))
        np.testing.assert_array_equal(nearest, _brute_nearest_depot(units))
        assert nearest[1] == 0  # The tie.
        assert nearest[16] == 16 and nearest[17] == -1  # The enemy's own; a field has none.
    assert np.asarray(nearest_depot(many))[27] == 2 * DEPOT_SLOTS  # The fifth.
    # A batch of both: the environment with more Command Centers measures to all of them.
    batch = jax.tree_util.tree_map(lambda a, b: jnp.stack([a, b]), few, many)
    nearest = np.asarray(jax.jit(jax.vmap(nearest_depot))(batch))
    np.testing.assert_array_equal(nearest[0], _brute_nearest_depot(few))
    np.testing.assert_array_equal(nearest[1], _brute_nearest_depot(many))


def test_a_mule_mines_25_beside_an_scv_and_only_another_mule_keeps_it_waiting():
    # An SCV (slot 2) and two MULEs (3, 4) reach the field together, 8 loops away. The
    # SCV and the first MULE mine at once, side by side; the second MULE waits for the
    # first. The MULE mines 3.85 times as long as the SCV: 171.6 loops, done on the 172nd.
    units = scene([33.0, 33.0, 33.0])
    units = units.replace(type=units.type.at[3].set(UnitType.MULE).at[4].set(UnitType.MULE))
    touched = math.ceil((FIELD[0] - R_FIELD - R_SCV - REACH - 33.0) / SPEED)
    units, _ = run(units, touched + 1)
    work = np.asarray(units.work)[2:5]
    assert work[0] > 0 and work[1] > 0 and work[2] == 0
    assert MULE_MINING_LOOPS == 3.85 * MINING_LOOPS
    units, _ = run(units, math.ceil(MULE_MINING_LOOPS) - 1)
    np.testing.assert_array_equal(np.asarray(units.cargo)[3:5], [25.0, 0.0])
    assert float(units.work[4]) > 0  # The second MULE mines once the first has left.
