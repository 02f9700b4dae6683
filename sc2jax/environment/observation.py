"""Builds the padded observation (specs.observation_spec(padded=True)) from the state."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from sc2jax.environment import observation_tables as tables
from sc2jax.environment import production, specs
from sc2jax.environment.availability import (
    CARD_TABLE,
    army_count,
    available_actions,
    idle_worker_count,
)
from sc2jax.environment.functions import FUNCTIONS
from sc2jax.environment.harvest import nearest_depot
from sc2jax.environment.render import Renderer, player_relative, ratio_255
from sc2jax.environment.state import EnvState, Order, Owner, Units
from sc2jax.environment.ui import NUM_GROUPS, selection_order
from sc2jax.environment.units import UNIT_DATA, UnitType

TERRAN = 1  # sc2api.proto Race.
BASE_RADIUS = 10.0
"""Mineral fields within this distance of a Command Center belong to its base."""

# The Train ability each trained unit type is queued with (`production_queue`).
_TRAIN_ABILITY = np.zeros(len(UnitType), np.int32)
for _unit, _function in ((UnitType.SCV, "Train_SCV_quick"),
                         (UnitType.MARINE, "Train_Marine_quick")):
    _TRAIN_ABILITY[_unit] = FUNCTIONS[_function].ability_id


def build_percent(units: Units):
    """int32[N]: construction progress in percent (100 for complete units)."""
    build_time = jnp.asarray(UNIT_DATA.build_time)[units.type]
    done = jnp.where(build_time > 0, units.progress / jnp.maximum(build_time, 1.0), 1.0)
    return jnp.floor(jnp.minimum(done, 1.0) * 100).astype(jnp.int32)


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

    A queued unit's vector is its type at full health, with the build progress of the
    one in training; `production_queue` rows are [Train ability id, progress %].
    """
    selected = units.selected & units.alive
    slot = jnp.argmax(selected)
    shown = (jnp.sum(selected) == 1) & units.complete[slot]
    queue = units.queue[slot]
    in_queue = shown & (queue != 0)
    time = jnp.asarray(UNIT_DATA.build_time)[queue]
    first = jnp.arange(queue.shape[0]) == 0
    percent = jnp.where(first, jnp.floor(units.queue_work[slot] / jnp.maximum(time, 1.0) * 100),
                        0).astype(jnp.int32)
    vectors = jnp.stack([
        jnp.asarray(UNIT_DATA.sc2_id)[queue], jnp.full_like(queue, 1),
        jnp.asarray(UNIT_DATA.max_health)[queue].astype(jnp.int32),
        jnp.asarray(UNIT_DATA.max_shields)[queue].astype(jnp.int32),
        jnp.zeros_like(queue), jnp.zeros_like(queue), percent], axis=-1)
    ability = jnp.asarray(_TRAIN_ABILITY)[queue]
    rows = jnp.stack([ability, percent], axis=-1)
    pad = lambda x: jnp.zeros((length, x.shape[1]), jnp.int32).at[:x.shape[0]].set(  # noqa: E731
        jnp.where(in_queue[:, None], x, 0)[:length])
    return pad(vectors), pad(rows)


def _player(state: EnvState):
    units = state.units
    own = units.alive & (units.owner == Owner.SELF)
    food = jnp.asarray(UNIT_DATA.food)[units.type]
    army = jnp.asarray(UNIT_DATA.is_army)[units.type]
    return jnp.stack([
        jnp.int32(Owner.SELF), state.minerals, state.vespene,
        jnp.ceil(production.food_used(units)).astype(jnp.int32),
        production.food_cap(units),
        jnp.ceil(jnp.sum(jnp.where(own & army, food, 0.0))).astype(jnp.int32),
        jnp.sum(own & (units.type == UnitType.SCV)).astype(jnp.int32),
        idle_worker_count(units), army_count(units), jnp.int32(0), jnp.int32(0),
    ]).astype(jnp.int32)


def _pad_rows(rows, mask, length, order=None):
    """Packs rows where mask into the first rows of a [length, ...] zero array."""
    position = jnp.cumsum(mask.astype(jnp.int32)) - 1 if order is None else order
    position = jnp.where(mask & (position < length), position, length)  # length = dropped
    out = jnp.zeros((length + 1,) + rows.shape[1:], rows.dtype)
    return out.at[position].set(rows)[:length]


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
    dist = jnp.sqrt(jnp.sum(diff * diff, axis=-1))
    depot = nearest_depot(units, dist)[home]
    count = lambda where, at: jnp.zeros(n, jnp.int32).at[  # noqa: E731
        jnp.where(where, at, n)].add(1, mode="drop")
    fields = units.alive & (units.type == UnitType.MINERAL_FIELD) & (units.contents > 0)
    cc = own & units.complete & (units.type == UnitType.COMMAND_CENTER)
    refinery = own & units.complete & (units.type == UnitType.REFINERY)
    near_fields = jnp.sum(fields[None, :] & (dist <= BASE_RADIUS), axis=1)
    assigned = jnp.where(cc, count(on_minerals & (depot >= 0), depot),
                         jnp.where(refinery, count(on_gas, home), 0))
    ideal = jnp.where(cc, 2 * near_fields, jnp.where(refinery & (units.contents > 0), 3, 0))
    return assigned.astype(jnp.int32), ideal.astype(jnp.int32)


def feature_units(units: Units, include, pixel_pos, pixel_radius, on_screen, length,
                  with_tags: bool):
    """int32[length, 46] `FeatureUnit` rows of the units where `include`, in slot order.

    Coordinates and radii are in the pixels of `pixel_pos`/`pixel_radius` (screen for
    `feature_units`, minimap for `raw_units`). Raw order ids are not reported (0).
    """
    d = UNIT_DATA
    t = units.type
    n = units.num_slots
    zeros = jnp.zeros(n, jnp.int32)
    # A producer's training queue is its orders, as in the game.
    order_length = jnp.sum(units.orders != Order.NONE, axis=1) + jnp.sum(units.queue != 0,
                                                                           axis=1)
    assigned, ideal = harvesters(units)
    columns = {
        "unit_type": jnp.asarray(d.sc2_id)[t],
        "alliance": player_relative(units.owner),
        "health": jnp.ceil(units.health).astype(jnp.int32),
        "shield": units.shields.astype(jnp.int32),
        "energy": units.energy.astype(jnp.int32),
        "build_progress": build_percent(units),
        "health_ratio": ratio_255(units.health, jnp.asarray(d.max_health)[t]),
        "shield_ratio": ratio_255(units.shields, jnp.asarray(d.max_shields)[t]),
        "energy_ratio": ratio_255(units.energy, jnp.asarray(d.max_energy)[t]),
        "display_type": jnp.ones(n, jnp.int32),
        "owner": units.owner,
        "x": jnp.floor(pixel_pos[:, 0]).astype(jnp.int32),
        "y": jnp.floor(pixel_pos[:, 1]).astype(jnp.int32),
        "facing": units.facing.astype(jnp.int32),
        "radius": pixel_radius.astype(jnp.int32),
        "cloak": jnp.full(n, 3),
        "is_selected": units.selected.astype(jnp.int32),
        "weapon_cooldown": units.cooldown.astype(jnp.int32),
        "order_length": order_length.astype(jnp.int32),
        "tag": units.tag if with_tags else zeros,
        "is_on_screen": on_screen.astype(jnp.int32),
        "mineral_contents": jnp.where(t == UnitType.MINERAL_FIELD, units.contents, 0),
        "vespene_contents": jnp.where((t == UnitType.VESPENE_GEYSER) | (t == UnitType.REFINERY),
                                      units.contents, 0),
        "assigned_harvesters": assigned,
        "ideal_harvesters": ideal,
    }
    rows = jnp.stack([columns.get(f.name, zeros).astype(jnp.int32)
                      for f in tables.FeatureUnit], axis=-1)
    return _pad_rows(rows, include, length)


def observe(state: EnvState, renderer: Renderer, card_table=CARD_TABLE) -> dict:
    """The padded observation dict of one environment."""
    fmt = renderer.fmt
    units = state.units
    vectors = unit_vectors(units)
    selected = units.selected & units.alive
    count = jnp.sum(selected)
    single = jnp.where(count == 1, vectors[jnp.argmax(selected)], 0)[None]
    multi = jnp.where(count > 1, _pad_rows(vectors, selected, fmt.max_units,
                                           selection_order(units)), 0)
    last_actions = jnp.full((specs.MAX_LAST_ACTIONS,), -1, jnp.int32).at[0].set(
        state.last_action)
    action_result = jnp.zeros((specs.MAX_LAST_ACTIONS,), jnp.int32).at[0].set(
        state.action_result)
    score_cumulative = state.score_cumulative.at[0].set(state.score)
    build_queue, production_queue = production_panel(units, specs.MAX_BUILD_QUEUE)
    obs = {
        "feature_screen": renderer.screen(state),
        "feature_minimap": renderer.minimap_layers(state),
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
        "upgrades": jnp.zeros((specs.MAX_UPGRADES,), jnp.int32),
        "home_race_requested": jnp.array([TERRAN], jnp.int32),
        "away_race_requested": jnp.zeros((1,), jnp.int32),
        "available_actions": available_actions(units, card_table),
    }
    if fmt.use_feature_units or fmt.use_raw_units:
        shown = renderer.units_shown(state)
        camera = renderer.camera
        screen_pos = camera.world_to_pixel(state.camera, units.pos)
        sx, sy = camera.size
        on_screen = ((screen_pos[:, 0] >= 0) & (screen_pos[:, 0] < sx)
                     & (screen_pos[:, 1] >= 0) & (screen_pos[:, 1] < sy))
        radius = jnp.asarray(UNIT_DATA.radius)[units.type]
    if fmt.use_feature_units:
        obs["feature_units"] = feature_units(
            units, shown & on_screen, screen_pos, radius * camera.pixels_per_unit, on_screen,
            fmt.max_units, with_tags=False)
    if fmt.use_raw_units:
        minimap = renderer.minimap
        obs["raw_units"] = feature_units(
            units, shown, minimap.world_to_pixel(units.pos), radius * minimap.pixels_per_unit,
            on_screen, fmt.max_units, with_tags=True)
    return obs
