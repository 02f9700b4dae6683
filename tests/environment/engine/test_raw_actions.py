"""The raw interface in the simulator: a raw action and the feature action that sends the
same ability to the same units, at the same point or unit, give the same game."""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.engine import raw_actions
from sc2jax.environment.engine.rules.geometry import clamp_camera
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.dense import to_dense
from sc2jax.environment.interface.functions import FUNCTIONS, RAW_FUNCTIONS
from sc2jax.environment.interface.functions import FunctionType as T
from sc2jax.environment.interface.observation_tables import FeatureUnit as FU
from sc2jax.environment.interface.protocol_enums import ActionResult
from sc2jax.environment.interface.raw import RawAction, to_raw_dense
from sc2jax.environment.interface.specs import ObservationFormat

MAP = "CollectMineralsAndGas"
# 24 screen pixels over the camera's 24 world units and the default raw grid (the 64 x 64
# map) put pixel centres on the same world points: screen pixel (p, q) is world
# (p + 21.5, 36.5 - q) with the camera at (33, 25), raw pixel (p + 21, q + 27).
FEATURES = ObservationFormat(screen_size=24, minimap_size=16, use_raw_units=True)
RAW = dataclasses.replace(FEATURES, action_space="raw")
CAMERA = (33.0, 25.0)
CC, FIELD, SCVS = 20, 0, (21, 22, 23)


def raw_pixel(screen_pixel):
    return (screen_pixel[0] + 21, screen_pixel[1] + 27)


def test_every_raw_function_but_unload_has_the_feature_function_of_its_ability():
    table = raw_actions.FEATURE_OF_RAW
    missing = [RAW_FUNCTIONS[i].name for i in np.flatnonzero(table < 0)]
    assert sorted(missing) == sorted(f.name for f in RAW_FUNCTIONS
                                     if f.name.startswith("UnloadUnit"))
    kinds = {T.raw_cmd: T.cmd_quick, T.raw_cmd_pt: T.cmd_screen, T.raw_cmd_unit: T.cmd_screen,
             T.raw_autocast: T.autocast, T.raw_no_op: T.no_op, T.raw_move_camera: T.move_camera}
    for raw, feature in zip(RAW_FUNCTIONS, table):
        if feature >= 0:
            assert FUNCTIONS[int(feature)].ability_id == raw.ability_id, raw.name
            assert FUNCTIONS[int(feature)].function_type == kinds[raw.function_type], raw.name
    assert table[RAW_FUNCTIONS.Attack_unit.id] == table[RAW_FUNCTIONS.Attack_pt.id] == \
        FUNCTIONS.Attack_screen.id
    assert table[RAW_FUNCTIONS.Train_SCV_quick.id] == FUNCTIONS.Train_SCV_quick.id


@functools.cache
def programs():
    """(start state, act with features, act raw, raw_units of a state, run 8 loops)."""
    feature_sim = Simulator(MAP, FEATURES, use_slot_sizes=False)
    raw_sim = Simulator(MAP, RAW, use_slot_sizes=False)
    state, _ = jax.jit(feature_sim.reset)(jax.random.PRNGKey(0))
    state = state.replace(camera=jnp.asarray(CAMERA, jnp.float32), minerals=jnp.int32(400))
    noop = jax.tree.map(jnp.asarray, to_dense(FUNCTIONS.no_op()))
    return (state, jax.jit(feature_sim.act), jax.jit(raw_sim.act),
            jax.jit(lambda s: raw_sim.observe(s)["raw_units"]),
            jax.jit(lambda s: feature_sim.advance(s, noop)), raw_sim)


def _selecting(state, slots):
    return state.replace(units=state.units.replace(
        selected=jnp.zeros(state.units.num_slots, bool).at[jnp.asarray(slots)].set(True)))


def _without_unit_targets_points(state):
    """The state with the points of orders on a unit zeroed: a feature action's is where
    it clicked, a raw action's the unit's position; the game reads neither (the unit
    heads for the unit it targets)."""
    units = state.units
    on_unit = (units.order_unit >= 0)[..., None]
    return state.replace(units=units.replace(order_pos=jnp.where(on_unit, 0.0,
                                                                 units.order_pos)))


def _same(a, b):
    a, b = _without_unit_targets_points(a), _without_unit_targets_points(b)
    for x, y in zip(jax.tree.leaves(jax.device_get(a)), jax.tree.leaves(jax.device_get(b))):
        np.testing.assert_array_equal(x, y)


def _row(raw_units, slot_tag):
    return int(np.flatnonzero(np.asarray(raw_units)[:, FU.tag] == slot_tag)[0])


CASES = {
    "move to a point": (SCVS, FUNCTIONS.Move_screen("now", (5, 3)),
                        lambda rows: RAW_FUNCTIONS.Move_pt("now", rows(SCVS), raw_pixel((5, 3)))),
    "queued move": (SCVS[:1], FUNCTIONS.Move_screen("queued", (12, 20)),
                    lambda rows: RAW_FUNCTIONS.Move_pt("queued", rows(SCVS[:1]),
                                                       raw_pixel((12, 20)))),
    "gather from a unit": (SCVS, FUNCTIONS.Harvest_Gather_screen("now", (1, 8)),
                           lambda rows: RAW_FUNCTIONS.Harvest_Gather_unit(
                               "now", rows(SCVS), rows((FIELD,))[0])),
    "train (quick)": ((CC,), FUNCTIONS.Train_SCV_quick("now"),
                      lambda rows: RAW_FUNCTIONS.Train_SCV_quick("now", rows((CC,)))),
    "build at a point": (SCVS[1:2], FUNCTIONS.Build_SupplyDepot_screen("now", (14, 4)),
                         lambda rows: RAW_FUNCTIONS.Build_SupplyDepot_pt(
                             "now", rows(SCVS[1:2]), raw_pixel((14, 4)))),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(CASES))
def test_a_raw_action_and_its_feature_action_give_the_same_game(case):
    start, act_features, act_raw, raw_units_of, run, raw_sim = programs()
    slots, feature_call, raw_call = CASES[case]
    rows = raw_units_of(start)
    as_rows = lambda slots: [_row(rows, s) for s in slots]  # noqa: E731  (tag = slot here)
    raw = jax.tree.map(jnp.asarray, to_raw_dense(raw_call(as_rows), rows,
                                                 raw_sim.renderer.raw_grid.size))
    by_features = act_features(_selecting(start, slots), to_dense(feature_call, FEATURES.types))
    by_raw = act_raw(start, raw)
    assert int(by_raw.action_result) == 0 and int(by_raw.last_action) == feature_call.function
    _same(by_features, by_raw)
    for _ in range(3):
        by_features, by_raw = run(by_features), run(by_raw)
    _same(by_features, by_raw)
    assert not np.array_equal(jax.device_get(by_raw.units.pos), jax.device_get(start.units.pos))


@pytest.mark.slow
def test_raw_move_camera_keeps_the_selection_and_unsupported_commands_do_nothing():
    start, _, act_raw, raw_units_of, _, raw_sim = programs()
    rows, grid = raw_units_of(start), raw_sim.renderer.raw_grid
    selected = _selecting(start, SCVS)
    moved = act_raw(selected, jax.tree.map(jnp.asarray, to_raw_dense(
        RAW_FUNCTIONS.raw_move_camera((30, 30)), rows, grid.size)))
    np.testing.assert_array_equal(moved.units.selected, selected.units.selected)
    # Raw pixel (30, 30) is world (30.5, 33.5); the camera centres there, kept in the map.
    np.testing.assert_array_equal(moved.camera, clamp_camera(
        raw_sim.renderer.geometry, jnp.asarray([30.5, 33.5], jnp.float32)))
    assert not np.array_equal(moved.camera, selected.camera)
    unloaded = act_raw(selected, jax.tree.map(jnp.asarray, to_raw_dense(
        RAW_FUNCTIONS.UnloadUnit_quick("now", [_row(rows, SCVS[0])]), rows, grid.size)))
    assert int(unloaded.action_result) == ActionResult.NotSupported
    _same(unloaded.replace(action_result=selected.action_result), selected)
    # A command its units cannot take selects them and is not supported, as a feature
    # action, at no cost.
    marines = act_raw(start, jax.tree.map(jnp.asarray, to_raw_dense(
        RAW_FUNCTIONS.Train_Marine_quick("now", [_row(rows, SCVS[0])]), rows, grid.size)))
    assert int(marines.action_result) == ActionResult.NotSupported
    assert int(marines.minerals) == int(start.minerals)
    assert np.flatnonzero(marines.units.selected).tolist() == [SCVS[0]]


@pytest.mark.slow
def test_the_raw_grid_is_pysc2s_and_rows_name_the_units_listed():
    start, _, act_raw, raw_units_of, _, raw_sim = programs()
    rows = np.asarray(raw_units_of(start))
    units = jax.device_get(start.units)
    cc = rows[_row(rows, CC)]
    # PySC2 v4: x * 64 / 64, (64 - y) * 64 / 64, floored.
    assert (cc[FU.x], cc[FU.y]) == (int(units.pos[CC, 0]), int(64 - units.pos[CC, 1]))
    assert cc[FU.unit_type] == 18 and int(units.type[CC]) == UnitType.COMMAND_CENTER
    # A tag that is no row stands for the unit of that tag, as in PySC2.
    tagged = rows.copy()
    tagged[_row(rows, CC), FU.tag] = 4_000_000
    call = RAW_FUNCTIONS.Train_SCV_quick("now", [4_000_000])
    assert np.flatnonzero(to_raw_dense(call, tagged, (64, 64)).units).tolist() == [
        _row(rows, CC)]
    with pytest.raises(ValueError, match="unit tag 999 is neither a row of the last raw_units"):
        to_raw_dense(RAW_FUNCTIONS.Stop_quick("now", [999]), rows, (64, 64))
    with pytest.raises(ValueError, match=r"'world' = \(64, 3\) is off the raw grid: x in 0..63"):
        to_raw_dense(RAW_FUNCTIONS.Move_pt("now", [0], (64, 3)), rows, (64, 64))
    with pytest.raises(ValueError, match="action space is 'raw': it takes a RawAction, got "
                                         "DenseAction"):
        raw_sim.act(start, to_dense(FUNCTIONS.no_op()))
    with pytest.raises(ValueError, match="units shape \\(64,\\)"):
        raw_sim.act(start, RawAction(*(jnp.asarray(a) for a in to_raw_dense(
            RAW_FUNCTIONS.no_op(), rows[:10], (64, 64)))))


@pytest.mark.slow
def test_raw_units_report_orders_as_raw_functions():
    start, _, act_raw, raw_units_of, _, raw_sim = programs()
    rows = raw_units_of(start)
    train = RAW_FUNCTIONS.Train_SCV_quick("now", [_row(rows, CC)])
    for _ in range(2):  # Two SCVs queued: both orders are listed.
        start = act_raw(start, jax.tree.map(jnp.asarray, to_raw_dense(train, rows, (64, 64))))
    cc = np.asarray(raw_units_of(start))[_row(rows, CC)]
    assert cc[FU.order_length] == 2
    assert cc[FU.order_id_0] == cc[FU.order_id_1] == RAW_FUNCTIONS.Train_SCV_quick.id
    assert cc[FU.order_id_2] == 0


@pytest.mark.slow
def test_raw_agents_see_the_raw_functions_their_units_can_call():
    start, _, _, _, _, raw_sim = programs()
    mask = np.asarray(jax.jit(lambda s: raw_sim.observe(s)["available_actions_mask"])(start))
    assert mask.shape == (len(RAW_FUNCTIONS),)
    available = {RAW_FUNCTIONS[i].name for i in np.flatnonzero(mask)}
    # The Command Center trains SCVs; the SCVs move, gather and build a Supply Depot (but
    # no Barracks without one); nothing trains a Marine. Only general functions, as the
    # feature interface shows them.
    assert {"no_op", "raw_move_camera", "Train_SCV_quick", "Move_pt", "Move_unit",
            "Harvest_Gather_unit", "Build_SupplyDepot_pt", "Attack_pt", "Attack_unit",
            "Smart_unit"} <= available
    assert not {"Train_Marine_quick", "Build_Barracks_pt", "Attack_Attack_pt",
                "UnloadUnit_quick"} & available
    assert mask[RAW_FUNCTIONS.Build_Refinery_pt.id] == mask[RAW_FUNCTIONS.Move_pt.id]
