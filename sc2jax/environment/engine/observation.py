"""Builds the padded observation (specs.observation_spec(padded=True)) from the state."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.actions import MAKE_ABILITY
from sc2jax.environment.engine.availability import (
    CARD_TABLE,
    army_count,
    available_actions,
    idle_worker_count,
    raw_available_actions,
)
from sc2jax.environment.engine.render import Renderer, player_relative
from sc2jax.environment.engine.rules import liftoff, players, production, research
from sc2jax.environment.engine.rules.geometry import squared_length
from sc2jax.environment.engine.rules.harvest import nearest_depot
from sc2jax.environment.engine.rules.state import EnvState, Order, Owner, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType, game_name
from sc2jax.environment.engine.ui import NUM_GROUPS, selection_order
from sc2jax.environment.interface import observation_tables as tables
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.feature_units import raw_unit_rows, screen_unit_rows
from sc2jax.environment.interface.functions import FUNCTIONS, SPECIFIC_ABILITY

BASE_RADIUS = 10.0
"""Mineral fields within this distance of a Command Center belong to its base."""

# The ability id the game reports for each `Order` in a unit's orders (BUILD and
# CONSTRUCT report the structure's Build ability).
ORDER_ABILITY = np.zeros(len(Order), np.int32)
for _order, _function in ((Order.MOVE, "Move_screen"), (Order.ATTACK_MOVE, "Attack_screen"),
                          (Order.ATTACK_UNIT, "Attack_screen"), (Order.PATROL, "Patrol_screen"),
                          (Order.HOLD, "HoldPosition_quick"),
                          (Order.GATHER, "Harvest_Gather_screen"),
                          (Order.RETURN, "Harvest_Return_quick")):
    ORDER_ABILITY[_order] = SPECIFIC_ABILITY[FUNCTIONS[_function].ability_id]
LAND_ABILITY = np.zeros(len(UnitType), np.int32)
"""The ability landing as each structure (a LAND order's type)."""
for _type in np.flatnonzero(liftoff.FLYING_FORM):
    LAND_ABILITY[_type] = FUNCTIONS[f"Land_{game_name(UnitType(_type))}_screen"].ability_id


def build_fraction(units: Units):
    """float32[N]: construction progress in [0, 1] (1 for complete units)."""
    build_time = jnp.asarray(UNIT_DATA.build_time)[units.type]
    done = jnp.where(build_time > 0, units.progress / jnp.maximum(build_time, 1.0), 1.0)
    return jnp.minimum(done, 1.0)


def build_percent(units: Units):
    """int32[N]: construction progress in percent (100 for complete units)."""
    return jnp.floor(build_fraction(units) * 100).astype(jnp.int32)


def unit_vectors(units: Units):
    """int32[N, 7]: each slot's `UnitLayer` vector (as the UI panels show it; the build
    progress is non-zero for unfinished structures only)."""
    progress = jnp.where(units.complete, 0, build_percent(units))
    return jnp.stack([
        jnp.asarray(UNIT_DATA.sc2_id)[units.type],
        player_relative(units.owner),
        jnp.ceil(units.health).astype(jnp.int32),
        units.shields.astype(jnp.int32),
        units.energy.astype(jnp.int32),
        jnp.zeros_like(units.type),
        progress,
    ], axis=-1).astype(jnp.int32)


def production_panel(units: Units, length: int):
    """(build_queue int32[length, 7], production_queue int32[length, 2]): the queue of
    the single selected unit, if it is training (the game's production panel).

    A queued unit's vector is its type at full health, with its build progress (of the
    one in training, or the two with a Reactor); `production_queue` rows are [Train or
    Research ability id, progress %]. A research has a row, and no unit vector. A
    Reactor's queue holds 8, others 5.
    """
    selected = units.selected & units.alive
    slot = jnp.argmax(selected)
    shown = (jnp.sum(selected) == 1) & units.complete[slot]
    queue = units.queue[slot]
    in_queue = shown & (queue != 0)
    time = jnp.asarray(production.ITEM_TIME)[queue]
    percent = jnp.floor(units.queue_work[slot] / jnp.maximum(time, 1.0) * 100).astype(jnp.int32)
    unit = jnp.where(queue < research.FIRST, queue, 0)
    vectors = jnp.stack([
        jnp.asarray(UNIT_DATA.sc2_id)[unit], jnp.full_like(queue, 1),
        jnp.asarray(UNIT_DATA.max_health)[unit].astype(jnp.int32),
        jnp.asarray(UNIT_DATA.max_shields)[unit].astype(jnp.int32),
        jnp.zeros_like(queue), jnp.zeros_like(queue), percent], axis=-1)
    ability = jnp.asarray(MAKE_ABILITY)[queue]
    rows = jnp.stack([ability, percent], axis=-1)
    pad = lambda x, shown: jnp.zeros((length, x.shape[1]), jnp.int32).at[:x.shape[0]].set(  # noqa: E731
        jnp.where(shown[:, None], x, 0)[:length])
    return pad(vectors, in_queue & (unit > 0)), pad(rows, in_queue)


def _player(state: EnvState):
    units = state.units
    own = units.alive & (units.owner == Owner.SELF)
    food = jnp.asarray(UNIT_DATA.food)[units.type]
    army = jnp.asarray(UNIT_DATA.is_army)[units.type]
    return jnp.stack([
        players.player_id(state), state.minerals, state.vespene,
        jnp.ceil(production.food_used(units)).astype(jnp.int32),
        production.food_cap(units),
        jnp.ceil(jnp.sum(jnp.where(own & army, food, 0.0))).astype(jnp.int32),
        jnp.sum(own & (units.type == UnitType.SCV)).astype(jnp.int32),
        idle_worker_count(units), army_count(units), jnp.int32(0), jnp.int32(0),
    ]).astype(jnp.int32)


def _row_positions(mask, length, order=None):
    """int32[N]: the row of each item where bool[N] mask, in order (`order`: int32[N]
    given rows), of a list of `length` rows; `length` for the items left out."""
    position = jnp.cumsum(mask.astype(jnp.int32)) - 1 if order is None else order
    return jnp.where(mask & (position < length), position, length)


def _pad_rows(rows, mask, length, order=None):
    """Packs rows where mask into the first rows of a [length, ...] zero array."""
    out = jnp.zeros((length + 1,) + rows.shape[1:], rows.dtype)
    return out.at[_row_positions(mask, length, order)].set(rows)[:length]


def rows_to_slots(shown, rows: int):
    """int32[rows]: the unit slot of each row of a padded unit list (`raw_units`) of the
    units where bool[N] `shown`, -1 past the last (the inverse of its packing)."""
    slots = jnp.full((rows + 1,), -1, jnp.int32)
    return slots.at[_row_positions(shown, rows)].set(
        jnp.arange(shown.shape[0], dtype=jnp.int32))[:rows]


def _control_groups(units: Units):
    groups = jnp.arange(NUM_GROUPS)
    member = units.alive[None, :] & ((units.groups[None, :] >> groups[:, None]) & 1 > 0)
    count = jnp.sum(member, axis=1)
    leader = jnp.argmax(member, axis=1)
    leader_type = jnp.where(count > 0, jnp.asarray(UNIT_DATA.sc2_id)[units.type[leader]], 0)
    return jnp.stack([leader_type, count], axis=-1).astype(jnp.int32)


def harvesters(units: Units):
    """(assigned, ideal) int32[N] of each Command Center and Refinery of the player.

    A Refinery's assigned workers are those harvesting from it, ideally 3 while it has
    gas; a Command Center's are those harvesting mineral fields whose nearest Command
    Center it is, ideally 2 per mineral field within `BASE_RADIUS`.
    """
    n = units.num_slots
    own = units.alive & (units.owner == Owner.SELF)
    order = units.orders[:, 0]
    worker = own & ((order == Order.GATHER) | (order == Order.RETURN)) & (units.home >= 0)
    home = jnp.clip(units.home, 0, n - 1)
    on_gas = worker & (units.type[home] == UnitType.REFINERY)
    on_minerals = worker & (units.type[home] == UnitType.MINERAL_FIELD)
    diff = units.pos[:, None, :] - units.pos[None, :, :]
    dist = jnp.sqrt(squared_length(diff))
    depot = nearest_depot(units, eps=0.0)[home]
    count = lambda where, at: jnp.zeros(n, jnp.int32).at[  # noqa: E731
        jnp.where(where, at, n)].add(1, mode="drop")
    fields = units.alive & (units.type == UnitType.MINERAL_FIELD) & (units.contents > 0)
    cc = own & units.complete & jnp.asarray(UNIT_DATA.town_hall)[units.type]
    refinery = own & units.complete & (units.type == UnitType.REFINERY)
    near_fields = jnp.sum(fields[None, :] & (dist <= BASE_RADIUS), axis=1)
    assigned = jnp.where(cc, count(on_minerals & (depot >= 0), depot),
                         jnp.where(refinery, count(on_gas, home), 0))
    ideal = jnp.where(cc, 2 * near_fields, jnp.where(refinery & (units.contents > 0), 3, 0))
    return assigned.astype(jnp.int32), ideal.astype(jnp.int32)


def api_units(state: EnvState, renderer: Renderer) -> dict:
    """Each unit slot as the SC2 API's `Unit` proto reports it in `raw_data.units`.

    Returns a dict of [N] arrays named as `FeatureUnit` columns where a column copies an
    API value (health, facing in radians in [0, 2pi), weapon_cooldown in loops, ...),
    plus the API values the other columns are computed from: `x`, `y` (world),
    `radius` (world units), `build_progress` and `order_progress_0` (fractions),
    `health_max`, `shield_max`, `energy_max`, and `order_abilities` int32[N, Q + B] (the
    ability id of each order, or of the add-on a producer builds, then of each queued
    unit; 0 for none), and `order_ability_k` (k < 4) the ability of the k-th order the
    API lists. `shown` marks the units the player sees (those the API reports).
    """
    d = UNIT_DATA
    units = state.units
    t = units.type
    n = units.num_slots
    camera = renderer.camera
    px, py = jnp.moveaxis(camera.world_to_pixel(state.camera, units.pos), -1, 0)
    sx, sy = camera.size
    build_or_construct = (units.orders == Order.BUILD) | (units.orders == Order.CONSTRUCT)
    built = jnp.where(units.orders == Order.CONSTRUCT,
                      t[jnp.clip(units.order_unit, 0, n - 1)], units.order_type)
    # A producer's first order is the add-on it builds, else the unit in training.
    kind, addon_done = production.addon_kinds(units)
    addon = jnp.clip(units.addon, 0, n - 1)
    building_addon = (kind > 0) & ~addon_done
    orders = jnp.where(build_or_construct, jnp.asarray(MAKE_ABILITY)[built], jnp.where(
        units.orders == Order.LAND, jnp.asarray(LAND_ABILITY)[units.order_type],
        jnp.asarray(ORDER_ABILITY)[units.orders]))
    orders = orders.at[:, 0].set(jnp.where(building_addon, jnp.asarray(MAKE_ABILITY)[t[addon]],
                                           orders[:, 0]))
    order_abilities = jnp.concatenate([orders, jnp.asarray(MAKE_ABILITY)[units.queue]], axis=1)
    listed = jnp.take_along_axis(  # The orders the API lists, in order.
        order_abilities, jnp.argsort(order_abilities == 0, axis=1, stable=True), axis=1)
    training = (units.orders[:, 0] == Order.NONE) & (units.queue[:, 0] != 0)
    train_time = jnp.asarray(production.ITEM_TIME)[units.queue[:, 0]]
    progress_0 = jnp.where(building_addon, build_fraction(units)[addon], jnp.where(
        training, units.queue_work[:, 0] / jnp.maximum(train_time, 1.0), 0.0))
    assigned, ideal = harvesters(units)
    return {
        "shown": renderer.units_shown(state),
        "unit_type": jnp.asarray(d.sc2_id)[t],
        "alliance": player_relative(units.owner),
        "owner": units.owner,
        "tag": units.tag,
        "health": units.health, "health_max": research.max_health(units, state.researched),
        "shield": units.shields, "shield_max": jnp.asarray(d.max_shields)[t],
        "energy": units.energy, "energy_max": jnp.asarray(d.max_energy)[t],
        "build_progress": build_fraction(units),
        "display_type": jnp.ones(n, jnp.int32),  # Visible.
        "x": units.pos[:, 0], "y": units.pos[:, 1],
        "facing": jnp.mod(units.facing, 2 * np.pi),
        "radius": jnp.asarray(d.radius)[t],
        "cloak": jnp.full(n, 3, jnp.int32),  # NotCloaked.
        "is_selected": units.selected.astype(jnp.int32),
        "is_on_screen": ((px >= 0) & (px < sx) & (py >= 0) & (py < sy)).astype(jnp.int32),
        "mineral_contents": jnp.where(t == UnitType.MINERAL_FIELD, units.contents,
                                      0).astype(jnp.int32),
        "vespene_contents": jnp.where((t == UnitType.VESPENE_GEYSER)
                                      | (t == UnitType.REFINERY), units.contents,
                                      0).astype(jnp.int32),
        "assigned_harvesters": assigned,
        "ideal_harvesters": ideal,
        "weapon_cooldown": units.cooldown,
        "order_abilities": order_abilities,
        "order_length": jnp.sum(order_abilities != 0, axis=1).astype(jnp.int32),
        "order_progress_0": progress_0,
        **{f"order_ability_{k}": listed[:, k] for k in range(4)},
    }


def observe(state: EnvState, renderer: Renderer, card_table=CARD_TABLE,
            previous: dict | None = None, economy: bool = False) -> dict:
    """The padded observation dict of one environment.

    Args:
      previous: None, or an observation this renderer made before (of any state): its
        feature layers are written into (`Renderer._draw`), so a loop that carries the
        observation rewrites only the layers that can change.
      economy: (static) the map has production, and so research (`apply_action`).
    """
    fmt = renderer.fmt
    units = state.units
    vectors = unit_vectors(units)
    selected = units.selected & units.alive
    count = jnp.sum(selected)
    single = jnp.where(count == 1, vectors[jnp.argmax(selected)], 0)[None]
    multi = jnp.where(count > 1, _pad_rows(vectors, selected, fmt.max_units,
                                           selection_order(units)), 0)
    # PySC2 reports no last actions to raw agents.
    last_actions = jnp.full((specs.MAX_LAST_ACTIONS,), -1, jnp.int32).at[0].set(
        -1 if fmt.action_space == "raw" else state.last_action)
    action_result = jnp.zeros((specs.MAX_LAST_ACTIONS,), jnp.int32).at[0].set(
        state.action_result)
    score_cumulative = state.score_cumulative.at[0].set(state.score)
    build_queue, production_queue = production_panel(units, specs.MAX_BUILD_QUEUE)
    obs = {
        "feature_screen": renderer.screen(
            state, None if previous is None else previous["feature_screen"]),
        "feature_minimap": renderer.minimap_layers(
            state, None if previous is None else previous["feature_minimap"]),
        "player": _player(state),
        "game_loop": state.game_loop[None].astype(jnp.int32),
        "score_cumulative": score_cumulative.astype(jnp.int32),
        "score_by_category": jnp.zeros((len(tables.ScoreByCategory),
                                        len(tables.ScoreCategories)), jnp.int32),
        "score_by_vital": state.score_by_vital.astype(jnp.int32),
        "single_select": single.astype(jnp.int32),
        "multi_select": multi.astype(jnp.int32),
        "build_queue": build_queue,
        "production_queue": production_queue,
        "cargo": jnp.zeros((specs.MAX_CARGO, len(tables.UnitLayer)), jnp.int32),
        "cargo_slots_available": jnp.zeros((1,), jnp.int32),
        "control_groups": _control_groups(units),
        "last_actions": last_actions,
        "action_result": action_result,
        "alerts": jnp.zeros((specs.MAX_ALERTS,), jnp.int32),
        "upgrades": _pad_rows(jnp.asarray(research.UPGRADE_ID), state.researched,
                              specs.MAX_UPGRADES),
        "home_race_requested": jnp.array([tables.TERRAN], jnp.int32),
        "away_race_requested": jnp.zeros((1,), jnp.int32),
        "available_actions_mask": (raw_available_actions if fmt.action_space == "raw"
                                   else available_actions)(
            units, card_table, state.researched if economy else None),
    }
    if fmt.use_feature_units or fmt.use_raw_units:
        api = api_units(state, renderer)
    if fmt.use_feature_units:
        obs["feature_units"] = _pad_rows(
            screen_unit_rows(api, renderer.camera, state.camera),
            api["shown"] & (api["is_on_screen"] > 0), fmt.max_units)
    if fmt.use_raw_units:
        obs["raw_units"] = _pad_rows(raw_unit_rows(api, renderer.raw_grid), api["shown"],
                                     fmt.max_units)
    return obs
