"""Observations as StarCraft II API `ResponseObservation` protos, and back.

`decode` is what a client does with the game's reply (PySC2's `Features.transform_obs`,
reference/pysc2_facts.md §1): it builds the observation dict in PySC2's layout, the one
`SC2Env` returns. `encode` is what the simulator's SC2-API server sends: it writes a
padded simulator observation into the proto so that `decode` gives back exactly
`to_pysc2_layout` of it. The unit lists travel as the game sends them, as `Unit` protos
in `raw_data.units` (`encode_units`), from which `decode_units` builds `feature_units`
and `raw_units` with the simulator's own row code.

Both follow the wire format of the real game:
- feature layers are `ImageData`, rows top to bottom, at 1 bit per pixel (most
  significant bit first, rows not padded), 8 bits, or 32-bit little-endian ints;
- scores are floats, unit build progress a fraction in [0, 1];
- `available_actions` is computed from the command card's `abilities` and the UI
  panels by PySC2's rules (§2.4).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sc2jax.environment.interface import observation_tables as tables
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.camera import Camera, RawGrid
from sc2jax.environment.interface.feature_units import raw_unit_rows, screen_unit_rows
from sc2jax.environment.interface.functions import (
    ALWAYS,
    FUNCTIONS,
    SPECIFIC_ABILITY,
    FunctionCall,
    FunctionType,
)
from sc2jax.environment.sc2api.proto_actions import VISIBLE_FUNCTION, from_proto, to_proto
from sc2jax.environment.sc2api.protos import sc2api

CURRICULUM = 1
"""`score.proto` ScoreType Curriculum: the mini-games' score."""

_SCORE_DETAILS = tuple(f.name for f in tables.ScoreCumulative)[1:]
_POINT_TYPES = (FunctionType.cmd_screen, FunctionType.cmd_minimap)
_POINT_REQUIRED = {
    False: (FunctionType.cmd_quick, FunctionType.autocast),
    True: (FunctionType.cmd_screen, FunctionType.cmd_minimap, FunctionType.autocast),
}
_BY_ABILITY: dict[int, list] = {}
for _f in FUNCTIONS:
    if _f.ability_id:
        _BY_ABILITY.setdefault(_f.ability_id, []).append(_f)
_ALWAYS = [FUNCTIONS[name].id for name in ALWAYS]


# Feature layers.

def encode_image(layer: np.ndarray, scale: int):
    """`ImageData` of one (H, W) layer: 1 bit for 2-valued layers, else 8 or 32 bits
    (32 whenever a value does not fit in 8 bits, so nothing is clipped)."""
    layer = np.asarray(layer)
    image = sc2api.ImageData()
    image.size.x, image.size.y = layer.shape[1], layer.shape[0]
    low, high = (int(layer.min()), int(layer.max())) if layer.size else (0, 0)
    if scale <= 2 and low >= 0 and high <= 1:
        image.bits_per_pixel, image.data = 1, np.packbits(layer.astype(np.uint8)).tobytes()
    elif low >= 0 and high <= 255:
        image.bits_per_pixel, image.data = 8, layer.astype(np.uint8).tobytes()
    else:
        image.bits_per_pixel, image.data = 32, layer.astype("<i4").tobytes()
    return image


def decode_image(image) -> np.ndarray:
    """int32 (size.y, size.x) of an `ImageData`; zeros of shape (0, 0) when unset.

    Raises:
      ValueError: for an unknown bit depth or data of the wrong length.
    """
    width, height = image.size.x, image.size.y
    bits = image.bits_per_pixel
    if bits == 1:
        data = np.unpackbits(np.frombuffer(image.data, np.uint8))[:width * height]
    elif bits == 8:
        data = np.frombuffer(image.data, np.uint8)
    elif bits == 16:
        data = np.frombuffer(image.data, "<u2")
    elif bits == 32:
        data = np.frombuffer(image.data, "<i4")
    elif width * height == 0:
        return np.zeros((height, width), np.int32)
    else:
        raise ValueError(f"ImageData bits_per_pixel {bits} is not supported; allowed 1, 8, "
                         f"16 or 32")
    if data.size != width * height:
        raise ValueError(f"ImageData of {width}x{height} at {bits} bits has {len(image.data)} "
                         f"bytes")
    return data.reshape(height, width).astype(np.int32)


def _decode_layers(proto, layers, size) -> np.ndarray:
    (w, h), out = size, np.zeros((len(layers), size[1], size[0]), np.int32)
    for i, feature in enumerate(layers):
        if proto.HasField(feature.name):
            image = decode_image(getattr(proto, feature.name))
            if image.shape == (h, w):
                out[i] = image
            elif image.size:
                raise ValueError(f"feature layer {feature.name!r} is {image.shape[::-1]}; "
                                 f"the interface asked for {(w, h)}")
    return out


# Unit vectors.

def _progress(percent: int) -> float:
    """A build-progress fraction whose `int(x * 100)` is `percent` (PySC2's decoding)."""
    return percent / 100 if percent in (0, 100) else (percent + 0.5) / 100


def _unit_info(row, proto) -> None:
    (proto.unit_type, proto.player_relative, proto.health, proto.shields, proto.energy,
     proto.transport_slots_taken) = (int(v) for v in row[:6])
    proto.build_progress = _progress(int(row[6]))


def _unit_vector(info) -> list[int]:
    return [info.unit_type, info.player_relative, info.health, info.shields, info.energy,
            info.transport_slots_taken, int(info.build_progress * 100)]


def _rows(vectors, width: int) -> np.ndarray:
    return np.array(vectors, np.int32).reshape(-1, width)


# Unit lists (`raw_data.units`).

# API `Unit` fields copied straight into the `FeatureUnit` column of the same name.
_UNIT_FIELDS = ("unit_type", "alliance", "owner", "display_type", "cloak", "is_selected",
                "is_on_screen", "is_blip", "is_powered", "mineral_contents",
                "vespene_contents", "cargo_space_taken", "cargo_space_max",
                "assigned_harvesters", "ideal_harvesters", "attack_upgrade_level",
                "armor_upgrade_level", "shield_upgrade_level", "buff_duration_remain",
                "buff_duration_max")
# Float fields, kept in float32 as on the wire (the simulator computes in float32 too).
_UNIT_FLOATS = ("health", "health_max", "shield", "shield_max", "energy", "energy_max",
                "build_progress", "facing", "radius", "weapon_cooldown")
# Columns under another name in the API.
_UNIT_RENAMED = {"hallucination": "is_hallucination", "active": "is_active"}


def encode_units(api: dict, raw_data) -> None:
    """Appends the shown units of `observation.api_units` (numpy) to `raw_data.units`,
    in slot order."""
    for i in np.flatnonzero(api["shown"]):
        unit = raw_data.units.add()
        for name in _UNIT_FIELDS + _UNIT_FLOATS:
            if name in api:
                setattr(unit, name, api[name][i].item())
        unit.tag = int(api["tag"][i])
        unit.pos.x, unit.pos.y = float(api["x"][i]), float(api["y"][i])
        for k, ability_id in enumerate(api["order_abilities"][i][api["order_abilities"][i] != 0]):
            order = unit.orders.add(ability_id=int(ability_id))
            if k == 0 and api["order_progress_0"][i]:
                order.progress = float(api["order_progress_0"][i])


def _decode_api_units(units) -> dict:
    """The `observation.api_units`-style [n] numpy columns of `Unit` protos (PySC2's
    `full_unit_vec` reads the same fields)."""
    tags = {u.tag: u.unit_type for u in units}
    out = {name: np.array([getattr(u, name) for u in units], np.int64)
           for name in _UNIT_FIELDS}
    out.update({name: np.array([getattr(u, name) for u in units], np.float32)
                for name in _UNIT_FLOATS})
    out.update({column: np.array([getattr(u, name) for u in units], np.int64)
                for column, name in _UNIT_RENAMED.items()})
    out["tag"] = np.array([u.tag for u in units], np.uint64).astype(np.int64)
    out["x"] = np.array([u.pos.x for u in units], np.float32)
    out["y"] = np.array([u.pos.y for u in units], np.float32)
    out["order_length"] = np.array([len(u.orders) for u in units], np.int64)
    for k in range(4):
        out[f"order_ability_{k}"] = np.array(
            [u.orders[k].ability_id if len(u.orders) > k else 0 for u in units], np.int64)
    for k in range(2):
        out[f"order_progress_{k}"] = np.array(
            [u.orders[k].progress if len(u.orders) > k else 0 for u in units], np.float32)
    for k in range(2):
        out[f"buff_id_{k}"] = np.array(
            [u.buff_ids[k] if len(u.buff_ids) > k else 0 for u in units], np.int64)
    out["addon_unit_type"] = np.array(
        [tags.get(u.add_on_tag, 0) if u.add_on_tag else 0 for u in units], np.int64)
    return out


def decode_units(units, fmt: specs.ObservationFormat, camera_center,
                 map_size) -> dict:
    """`feature_units` and/or `raw_units` (int64 [n, 46], as PySC2 gives them) of the
    `Unit` protos of `raw_data.units`, as `fmt` asks.

    `feature_units` are the units on screen, in screen pixels of the camera centred at
    `camera_center` (world x, y); `raw_units` are all the units, in pixels of the raw
    grid (`fmt.raw_resolution`, by default `map_size`) over a map of `map_size` (width,
    height), with tags.
    """
    api = _decode_api_units(units)
    out = {}
    if fmt.use_feature_units:
        rows = screen_unit_rows(api, Camera(fmt.screen_size),
                                np.asarray(camera_center, np.float32), np.int64)
        out["feature_units"] = rows[api["is_on_screen"] != 0]
    if fmt.use_raw_units:
        grid = RawGrid(fmt.raw_resolution or tuple(map_size), tuple(map_size))
        out["raw_units"] = raw_unit_rows(api, grid, np.int64)
    return out


# Available actions.

def available_abilities(mask: np.ndarray) -> list[tuple[int, bool]]:
    """(ability_id, requires_point) pairs for the ability functions in a mask, with the
    specific ability ids the game reports for the simulator's units
    (`functions.SPECIFIC_ABILITY`)."""
    pairs = []
    for fid in np.flatnonzero(mask):
        func = FUNCTIONS[int(fid)]
        if func.ability_id:
            ability_id = SPECIFIC_ABILITY.get(func.ability_id, func.ability_id)
            pair = (ability_id, func.function_type in _POINT_TYPES)
            if pair not in pairs:
                pairs.append(pair)
    return pairs


def available_actions(abilities, player: np.ndarray, panel: str | None,
                      hide_specific_actions: bool = True) -> np.ndarray:
    """int32 sorted function ids, by PySC2's rules (§2.4).

    Args:
      abilities: `AvailableAbility` protos (or (ability_id, requires_point) pairs).
      player: the `player` vector.
      panel: the UI panel shown: "single", "multi", "cargo", "production" or None.
      hide_specific_actions: expose specific abilities through their general function
        only (PySC2's default).
    """
    available = set(_ALWAYS)
    conditions = {"select_unit": panel == "multi",
                  "select_idle_worker": player[tables.Player.idle_worker_count] > 0,
                  "select_army": player[tables.Player.army_count] > 0,
                  "select_warp_gates": player[tables.Player.warp_gate_count] > 0,
                  "select_larva": player[tables.Player.larva_count] > 0,
                  "unload": panel == "cargo", "build_queue": panel == "production"}
    available.update(FUNCTIONS[name].id for name, shown in conditions.items() if shown)
    for ability in abilities:
        ability_id, requires_point = (ability if isinstance(ability, tuple) else
                                      (ability.ability_id, ability.requires_point))
        for func in _BY_ABILITY.get(ability_id, ()):
            if func.function_type not in _POINT_REQUIRED[bool(requires_point)]:
                continue
            if func.general_id == 0 or not hide_specific_actions:
                available.add(func.id)
            if func.general_id:
                available.add(VISIBLE_FUNCTION[(func.ability_id, func.function_type)])
    return np.array(sorted(available), np.int32)


# The whole observation.

def encode(obs: dict, fmt: specs.ObservationFormat, *, result: int | None = None,
           player_id: int = 1):
    """The `ResponseObservation` of one padded simulator observation (numpy).

    Args:
      obs: a padded observation (`Simulator.observe`, on the host).
      fmt: its format.
      result: the `sc2api.Result` of the player when the game has ended, else None.
      player_id: the player's id.
    """
    response = sc2api.ResponseObservation()
    for fid in obs["last_actions"][obs["last_actions"] >= 0]:
        # `last_actions` keeps function ids only; the arguments do not matter to it.
        func = FUNCTIONS[int(fid)]
        zeros = [[0, 0] if a.is_point else [0] for a in func.args]
        response.actions.append(to_proto(FunctionCall(func.id, zeros)))
    for code in obs["action_result"][obs["action_result"] != 0]:
        response.action_errors.add(result=int(code))
    if result is not None:
        response.player_result.add(player_id=player_id, result=result)
    observation = response.observation
    observation.game_loop = int(obs["game_loop"][0])
    common = observation.player_common
    for field in tables.Player:
        setattr(common, field.name, int(obs["player"][field]))
    observation.alerts.extend(int(a) for a in obs["alerts"][obs["alerts"] != 0])
    for ability_id, requires_point in available_abilities(obs["available_actions_mask"]):
        observation.abilities.add(ability_id=ability_id, requires_point=requires_point)
    _encode_score(obs, observation.score)
    observation.raw_data.player.upgrade_ids.extend(
        int(u) for u in obs["upgrades"][obs["upgrades"] != 0])
    layers = observation.feature_layer_data
    for i, feature in enumerate(fmt.screen_layers):
        getattr(layers.renders, feature.name).CopyFrom(
            encode_image(obs["feature_screen"][i], feature.scale))
    for i, feature in enumerate(fmt.minimap_layers):
        getattr(layers.minimap_renders, feature.name).CopyFrom(
            encode_image(obs["feature_minimap"][i], feature.scale))
    _encode_ui(obs, observation.ui_data)
    return response


def _encode_score(obs: dict, score) -> None:
    score.score_type = CURRICULUM
    score.score = int(obs["score_cumulative"][0])
    details = score.score_details
    for i, name in enumerate(_SCORE_DETAILS, start=1):
        setattr(details, name, float(obs["score_cumulative"][i]))
    for row in tables.ScoreByCategory:
        category = getattr(details, row.name)
        for column in tables.ScoreCategories:
            setattr(category, column.name, float(obs["score_by_category"][row, column]))
    for row in tables.ScoreByVital:
        vital = getattr(details, row.name)
        for column in tables.ScoreVitals:
            setattr(vital, column.name, float(obs["score_by_vital"][row, column]))


def _encode_ui(obs: dict, ui) -> None:
    for index, (leader, count) in enumerate(obs["control_groups"]):
        if count:
            ui.groups.add(control_group_index=index, leader_unit_type=int(leader),
                          count=int(count))
    present = {key: obs[key][obs[key][:, 0] != 0]
               for key in ("single_select", "multi_select", "build_queue", "production_queue",
                           "cargo")}
    if len(present["multi_select"]):
        for row in present["multi_select"]:
            _unit_info(row, ui.multi.units.add())
    elif len(present["build_queue"]) or len(present["production_queue"]):
        production = ui.production
        _unit_info(obs["single_select"][0], production.unit)
        for row in present["build_queue"]:
            _unit_info(row, production.build_queue.add())
        for ability_id, percent in present["production_queue"]:
            production.production_queue.add(ability_id=int(ability_id),
                                            build_progress=_progress(int(percent)))
    elif len(present["cargo"]):
        cargo = ui.cargo
        _unit_info(obs["single_select"][0], cargo.unit)
        for row in present["cargo"]:
            _unit_info(row, cargo.passengers.add())
        cargo.slots_available = int(obs["cargo_slots_available"][0])
    elif len(present["single_select"]):
        _unit_info(present["single_select"][0], ui.single.unit)


def decode(response, fmt: specs.ObservationFormat, map_name: str,
           races: Sequence[int] = (1, 0), hide_specific_actions: bool = True,
           map_size: tuple[int, int] | None = None) -> dict:
    """The observation dict in PySC2's layout (as `SC2Env` returns it).

    Args:
      response: a `ResponseObservation`.
      fmt: the observation format asked for in the join.
      map_name: the map's name, as `game_info` reports it.
      races: (home, away) requested races, from `game_info` (0: none).
      hide_specific_actions: see `available_actions`.
      map_size: the map's (width, height) from `game_info` (`start_raw.map_size`);
        needed for `raw_units`.

    Raises:
      ValueError: if the reply does not fit the format (feature-layer sizes), or
        `raw_units` are asked for without `map_size`.
    """
    if fmt.use_raw_units and not map_size:
        raise ValueError(f"decoding raw_units needs the map size from game_info, got "
                         f"map_size={map_size!r}")
    observation = response.observation
    common, score, ui = observation.player_common, observation.score, observation.ui_data
    player = np.array([getattr(common, f.name) for f in tables.Player], np.int32)
    details = score.score_details
    unit = len(tables.UnitLayer)
    out = {
        "feature_screen": _decode_layers(observation.feature_layer_data.renders,
                                         fmt.screen_layers, fmt.screen_size),
        "feature_minimap": _decode_layers(observation.feature_layer_data.minimap_renders,
                                          fmt.minimap_layers, fmt.minimap_size),
        "player": player,
        "game_loop": np.array([observation.game_loop], np.int32),
        "score_cumulative": np.array(
            [score.score] + [getattr(details, name) for name in _SCORE_DETAILS], np.int32),
        "score_by_category": np.array(
            [[getattr(getattr(details, row.name), column.name)
              for column in tables.ScoreCategories] for row in tables.ScoreByCategory],
            np.int32),
        "score_by_vital": np.array(
            [[getattr(getattr(details, row.name), column.name)
              for column in tables.ScoreVitals] for row in tables.ScoreByVital], np.int32),
        "single_select": np.zeros((0, unit), np.int32),
        "multi_select": np.zeros((0, unit), np.int32),
        "build_queue": np.zeros((0, unit), np.int32),
        "production_queue": np.zeros((0, len(tables.ProductionQueue)), np.int32),
        "cargo": np.zeros((0, unit), np.int32),
        "cargo_slots_available": np.array([0], np.int32),
        "control_groups": np.zeros((tables.NUM_CONTROL_GROUPS, len(tables.ControlGroup)),
                                   np.int32),
    }
    for group in ui.groups:
        out["control_groups"][group.control_group_index] = (group.leader_unit_type, group.count)
    panel = ui.WhichOneof("panel")
    if panel == "single":
        out["single_select"] = _rows([_unit_vector(ui.single.unit)], unit)
    elif panel == "multi":
        out["multi_select"] = _rows([_unit_vector(u) for u in ui.multi.units], unit)
    elif panel == "cargo":
        out["single_select"] = _rows([_unit_vector(ui.cargo.unit)], unit)
        out["cargo"] = _rows([_unit_vector(u) for u in ui.cargo.passengers], unit)
        out["cargo_slots_available"] = np.array([ui.cargo.slots_available], np.int32)
    elif panel == "production":
        production = ui.production
        out["single_select"] = _rows([_unit_vector(production.unit)], unit)
        out["build_queue"] = _rows([_unit_vector(u) for u in production.build_queue], unit)
        out["production_queue"] = _rows(
            [[item.ability_id, int(item.build_progress * 100)]
             for item in production.production_queue], len(tables.ProductionQueue))
    out["last_actions"] = np.array([from_proto(a).function for a in response.actions],
                                   np.int32)
    out["action_result"] = np.array([e.result for e in response.action_errors], np.int32)
    out["alerts"] = np.array(list(observation.alerts), np.int32)
    out["upgrades"] = np.array(list(observation.raw_data.player.upgrade_ids), np.int32)
    out["home_race_requested"] = np.array([races[0]], np.int32)
    out["away_race_requested"] = np.array([races[1]], np.int32)
    out["available_actions"] = available_actions(observation.abilities, player, panel,
                                                 hide_specific_actions)
    if fmt.use_feature_units or fmt.use_raw_units:
        camera = observation.raw_data.player.camera
        out.update(decode_units(observation.raw_data.units, fmt, (camera.x, camera.y),
                                map_size))
    out["map_name"] = map_name
    return out

