"""Replay decoding and action labels on the professional replays in ../shared/replays."""

import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest
from s2protocol import decoders as s2_decoders

from sc2jax.environment.interface.camera import Camera
from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES
from sc2jax.environment.interface.functions import (
    FUNCTIONS,
    FunctionType,
    function_for_ability,
)
from sc2jax.replay_sl import (
    ReplayError,
    label_actions,
    label_players,
    open_replay,
    read_metadata,
)
from sc2jax.replay_sl.abilities import resolve
from sc2jax.replay_sl.actions import _Positions, removed_indices
from sc2jax.replay_sl.archive import protocol_build_for
from sc2jax.replay_sl.fast_bits import FastBitBuffer, decoding_fast
from sc2jax.replay_sl.metadata import clean_name
from sc2jax.replay_sl.movement import speed
from sc2jax.replay_sl.observations import View, observe_step
from sc2jax.replay_sl.positions import errors as position_errors
from sc2jax.replay_sl.positions import estimate
from sc2jax.replay_sl.units import stable_unit_ids, unit_index, unit_table

REPLAYS = pathlib.Path(__file__).parents[3] / "shared" / "replays"
if not REPLAYS.is_dir():
    pytest.skip(f"the replays are not at {REPLAYS}", allow_module_level=True)
MANIFEST = {r["file"]: r for r in json.loads((REPLAYS / "MANIFEST.json").read_text())["replays"]}
KAIROS = "asus_rog/0001_KairosJunction.SC2Replay"  # 4.9.3, base build 75025
SLEEPERS = "nation_wars/0241_WorldofSleepers.SC2Replay"  # 4.10.4: no protocol of its own


# 0143: the details name no lobby slot; the tracker's PlayerSetup events do.
@pytest.mark.parametrize("name", [KAIROS, SLEEPERS, "nation_wars/0328_Triton.SC2Replay",
                                  "asus_rog/0143_Thunderbird.SC2Replay"])
def test_metadata_matches_the_manifest(name):
    replay = open_replay(REPLAYS / name)
    meta, expected = read_metadata(replay), MANIFEST[name]
    assert meta.base_build == expected["base_build"] and meta.version == expected["version"]
    assert meta.game_loops == expected["game_loops"] and meta.map_name == expected["map"]
    assert [(p.player_id, p.race, p.result) for p in meta.players] == [
        (i + 1, p["race"], p["result"]) for i, p in enumerate(expected["players"])]
    assert [p.name for p in meta.players] == [clean_name(p["name"].encode())
                                              for p in expected["players"]]


def test_a_build_without_a_protocol_decodes_with_the_nearest_lower_one():
    assert protocol_build_for(76811) == 76114 and protocol_build_for(75025) == 75025
    replay = open_replay(REPLAYS / SLEEPERS)  # validated while opening
    assert replay.base_build == 76811 and replay.protocol_build == 76114
    with pytest.raises(ValueError, match="older than every protocol"):
        protocol_build_for(100)


def test_observers_are_not_players_and_their_events_are_not_labelled():
    replay = open_replay(REPLAYS / KAIROS)
    meta = read_metadata(replay)
    assert [p.user_id for p in meta.players] == [2, 4]
    assert set(meta.observer_user_ids) == {0, 1, 3, 5, 6, 7}
    per_user = {}
    for e in replay.game_events():
        per_user[e["_userid"]["m_userId"]] = per_user.get(e["_userid"]["m_userId"], 0) + 1
    labels = label_actions(replay, meta, 1)
    assert sum(labels.coverage.events.values()) == per_user[2]
    with pytest.raises(ValueError, match=r"player 3 is not in this replay; its players are"):
        label_actions(replay, meta, 3)


def test_a_known_command_at_a_known_loop():
    # Player 1 (user 2) orders a supply depot at game loop 377 (TerranBuild, command 1) at
    # world (38, 129): step 47 (loops 376..383) is Build_SupplyDepot_screen, now, at the
    # point projected through the camera's centre of that moment.
    replay = open_replay(REPLAYS / KAIROS)
    labels = label_actions(replay, read_metadata(replay), 1)
    camera = None
    for e in replay.game_events():
        if (e["_userid"]["m_userId"] == 2 and e["_event"].endswith("SCameraUpdateEvent")
                and e["_gameloop"] <= 377 and e["m_target"] is not None):
            camera = (e["m_target"]["x"] / 256, e["m_target"]["y"] / 256)
    pixel = Camera((64, 64)).world_to_pixel(np.float32(camera), np.float32([38.0, 129.0]))
    step = labels.steps[377 // 8]
    assert step.game_loop == 376 and step.event == "CmdEvent"
    assert step.call.function == FUNCTIONS.Build_SupplyDepot_screen.id
    assert step.call.arguments == [[0], [int(pixel[0]), int(pixel[1])]]
    # Steps without an action are no_op, and there is one step per 8 loops.
    assert len(labels.steps) == replay.game_loops // 8 + 1
    assert labels.steps[1].game_loop == 8


def test_remove_masks_are_read_as_the_game_writes_them():
    # A 10-index mask removing indices 0 and 9: byte 0 (bit 0 set) is read first, so it
    # is on top of the integer (bit 2); the leftover index 9 is bit 1.
    assert removed_indices(10, 0b0110) == {0, 9}
    assert removed_indices(5, 0b10001) == {0, 4}  # Shorter than a byte: bit i is index i.
    assert removed_indices(16, 0x80_01) == {7, 8}  # Byte 0 bit 7 on top, byte 1 bit 0 last.
    # The game trims a mask after its last removed unit: read so, the last index is set.
    replay = open_replay(REPLAYS / KAIROS)
    last_set = []
    for e in replay.game_events():
        if e["_event"] == "NNet.Game.SSelectionDeltaEvent":
            kind, value = next(iter(e["m_delta"]["m_removeMask"].items()))
            if kind == "Mask" and value[0] > 8 and value[0] % 8:
                last_set.append(value[0] - 1 in removed_indices(*value))
    assert len(last_set) > 20 and np.mean(last_set) > 0.9
    # The selection is kept in the game's order, by tag, which the indices refer to.
    labels = label_actions(replay, read_metadata(replay), 1)
    assert all(list(s) == sorted(s) for s in labels.selections)
    assert max(map(len, labels.selections)) > 8


def test_the_camera_projection_is_pysc2s():
    # 24 world units across 64 pixels: 8/3 pixels per unit, the camera's centre at the
    # screen's centre, y down on the screen.
    camera = Camera((64, 64))
    px = camera.world_to_pixel(np.float32([50, 50]), np.float32([[50, 50], [56, 50], [50, 56]]))
    np.testing.assert_allclose(px, [[32, 32], [48, 32], [32, 16]], atol=1e-4)


def test_abilities_map_to_pysc2_functions():
    # Link 155 of 4.9.3 trains an SCV; TerranBuild/1 is the supply depot; right clicks and
    # attacks go to the general functions, as PySC2's reverse_action does.
    assert resolve(75025, 155, 0, FunctionType.cmd_quick).function == FUNCTIONS.Train_SCV_quick.id
    assert resolve(76114, 129, 1, FunctionType.cmd_screen).function == (
        FUNCTIONS.Build_SupplyDepot_screen.id)
    assert function_for_ability(23, FunctionType.cmd_screen) == FUNCTIONS.Attack_screen.id
    assert function_for_ability(23, FunctionType.cmd_minimap) == FUNCTIONS.Attack_minimap.id
    assert resolve(76114, 10**6, 0, FunctionType.cmd_quick).function is None
    # sc2reader names the queen's training after the hatchery's morphs and the baneling's
    # morph after the zergling; stableid names them TrainQueen and MorphZerglingToBaneling.
    for build, link in ((76114, 243), (80949, 245)):
        assert resolve(build, link, 0, FunctionType.cmd_quick).function == (
            FUNCTIONS.Train_Queen_quick.id)
    assert resolve(76114, 73, 0, FunctionType.cmd_quick).function == (
        FUNCTIONS.Train_Baneling_quick.id)


def test_the_fast_bit_reader_reads_what_s2protocols_reads():
    data = bytes(range(7, 250, 13)) * 3
    for sizes in ([3, 5, 8, 1, 16, 7, 9, 32], [12, 1, 1, 30, 2, 64], [8] * 20):
        stock, fast = s2_decoders.BitPackedBuffer(data), FastBitBuffer(data)
        assert [stock.read_bits(n) for n in sizes] == [fast.read_bits(n) for n in sizes]
        stock.byte_align(), fast.byte_align()
        assert stock.used_bits() == fast.used_bits()
    with pytest.raises(s2_decoders.TruncatedError):
        FastBitBuffer(b"ab").read_bits(17)
    # A replay's streams decode (`open_replay` reads with the fast buffer) to the events
    # that s2protocol's own buffer gives.
    replay = open_replay(REPLAYS / SLEEPERS)
    with decoding_fast(), decoding_fast():  # Nests; hands s2protocol's buffer back.
        assert s2_decoders.BitPackedBuffer is FastBitBuffer
    assert s2_decoders.BitPackedBuffer is not FastBitBuffer
    for stream, events in (("game", replay.game_events()), ("tracker", replay.tracker_events())):
        decode = getattr(replay._protocol, f"decode_replay_{stream}_events")
        assert list(decode(replay._read(stream))) == events


def test_a_corrupt_and_a_truncated_file_are_replay_errors(tmp_path):
    corrupt = tmp_path / "corrupt.SC2Replay"
    corrupt.write_bytes(b"MPQ\x1b" + bytes(range(256)) * 40)
    with pytest.raises(ReplayError, match="corrupt.SC2Replay"):
        open_replay(corrupt)
    data = (REPLAYS / KAIROS).read_bytes()
    truncated = tmp_path / "truncated.SC2Replay"
    truncated.write_bytes(data[:len(data) // 2])
    with pytest.raises(ReplayError, match="truncated.SC2Replay"):
        replay = open_replay(truncated)
        for _ in replay.game_events():
            pass
    with pytest.raises(FileNotFoundError, match="no replay file"):
        open_replay(tmp_path / "missing.SC2Replay")


def test_replay_info_writes_the_steps_as_json(tmp_path):
    out = tmp_path / "actions.json"
    result = subprocess.run([sys.executable, "-m", "sc2jax.experiments.replay_info",
                             str(REPLAYS / SLEEPERS), "--actions", "--player=2",
                             f"--output={out}"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "player 2: BlyOnFire (Zerg), Win" in result.stdout
    data = json.loads(out.read_text())
    assert data["metadata"]["base_build"] == 76811
    assert data["metadata"]["players"][1] == {"player_id": 2, "name": "BlyOnFire",
                                              "race": "Zerg", "result": "Win"}
    steps = data["steps"]
    assert len(steps) == 12550 // 8 + 1 and steps[0] == {
        "game_loop": 0, "function": 1, "name": "move_camera", "arguments": [[11, 55]]}
    assert any(s["name"] == "no_op" and s["arguments"] == [] for s in steps)


def test_the_unit_table_counts_the_workers_that_player_stats_report():
    # The Terran's SCVs alive at each PlayerStats event (every 160 loops), counted from
    # births, deaths, type and owner changes, equal the game's own worker count.
    replay = open_replay(REPLAYS / KAIROS)
    table = unit_table(replay)
    scv = stable_unit_ids()["SCV"]
    loops, values = table.stats[1]
    reported = values[:, table.stat_names.index("m_scoreValueWorkersActiveCount")]
    counted = [int((table.alive(L) & (table.owners_at(L) == 1) & (table.types_at(L) == scv))
                   .sum()) for L in loops]
    assert len(loops) > 100 and counted == reported.astype(int).tolist()
    assert (table.unit_type > 0).all() and (table.died >= table.born).all()


def test_position_estimates_by_hand():
    # From (0, 0) at loop 0: an order to (10, 0) at loop 10, then to (10, 10) at loop 20;
    # at 0.5 units a loop the unit walks 5 units by loop 20, then 5 up by loop 30.
    orders = [(10, 10.0, 0.0), (20, 10.0, 10.0)]
    assert estimate("last", (0, 0.0, 0.0), orders, 30, speed=0.5) == (0.0, 0.0)
    assert estimate("target", (0, 0.0, 0.0), orders, 30, speed=0.5) == (10.0, 10.0)
    x, y = estimate("move", (0, 0.0, 0.0), orders, 30, speed=0.5)
    # (5, 0) -> towards (10, 10): 5 units along (5, 10)/|(5, 10)|.
    np.testing.assert_allclose((x, y), (5 + 5 / np.sqrt(125) * 5, 5 / np.sqrt(125) * 10))
    with pytest.raises(ValueError, match="unknown method 'teleport'"):
        estimate("teleport", (0, 0.0, 0.0), orders, 30)


def test_labels_walk_units_at_their_speed_towards_their_orders():
    # The labeller's points follow positions' "move" estimate: a Marine born at (0, 0)
    # and sent to (10, 0) at loop 16 is 8 loops of its speed along at loop 24, and
    # there once the walk is long enough; a Barracks sent anywhere stays put.
    def born(index, name, x, y):
        return {"_event": "NNet.Replay.Tracker.SUnitBornEvent", "m_unitTagIndex": index,
                "m_unitTypeName": name.encode(), "m_x": x, "m_y": y}

    positions = _Positions()
    positions.tracker(born(1, "Marine", 0, 0))
    positions.tracker(born(2, "Barracks", 5, 5))
    assert positions.move([1, 2], (10.0, 0.0), 16) == (1,)
    v = speed(stable_unit_ids()["Marine"])
    np.testing.assert_allclose(positions.point(1, 24), (8 * v, 0.0))
    assert positions.point(1, 24) == estimate("move", (0, 0.0, 0.0), [(16, 10.0, 0.0)], 24, v)
    now = positions.snapshot(16 + int(10 / v) + 1)
    assert now[1] == (10.0, 0.0) and now[2] == (5.0, 5.0) and not positions.walks
    positions.move([1], (10.0, 10.0), 200)
    positions.tracker({"_event": "NNet.Replay.Tracker.SUnitPositionsEvent",
                       "m_firstUnitIndex": 1, "m_items": [0, 3, 4]})  # A report ends it.
    assert positions.point(1, 300) == (3.0, 4.0) and not positions.walks


def test_orders_bring_estimates_closer_to_the_tracker_reports():
    # The tracker's positions reports of units that had orders since their last report:
    # following the orders is closer than the last report (measured: medians 33.1 world
    # units for the last report, 20.0 walking towards the orders' targets).
    replay = open_replay(REPLAYS / KAIROS)
    labels = label_players(replay, read_metadata(replay))
    orders = [o for label in labels.values() for o in label.orders]
    found = position_errors(unit_table(replay), orders)
    assert found["last"].size == found["move"].size > 500
    assert np.median(found["move"]) < 0.8 * np.median(found["last"])


def test_structures_stay_put_when_given_a_rally_point():
    # A rally point given to a Barracks or a Command Center is a command with a target
    # point; the structure stays where it was placed, and only units that move are in
    # an order.
    replay = open_replay(REPLAYS / KAIROS)
    labels = label_actions(replay, read_metadata(replay), 1)
    table = unit_table(replay)
    rally = [FUNCTIONS[s.call.function].name for s in labels.steps
             if FUNCTIONS[s.call.function].name.startswith("Rally_")]
    assert len(rally) > 5
    ids = stable_unit_ids()
    orders = labels.orders
    at = table.at([o.game_loop for o in orders])
    indices = unit_index(table.tag)
    types = [at.unit_type[n][np.isin(indices, o.units) & at.alive[n]]
             for n, o in enumerate(orders)]
    assert len(orders) > 500 and all(speed(t) > 0 for ts in types for t in ts)
    assert sum(len(ts) for ts in types) > 1000 and ids["Barracks"] not in np.concatenate(types)
    structures = np.isin(table.unit_type, [ids["Barracks"], ids["CommandCenter"]]) & (
        table.owner == 1)
    structures[table.type_changes[:, 1]] = False  # Lifted off, or made an Orbital Command.
    assert structures.sum() >= 3
    for t in range(0, len(labels.steps), 97):
        known = dict(zip(labels.unit_points[t].index.tolist(),
                         labels.unit_points[t].xy.tolist()))
        for row in np.flatnonzero(structures):
            index = int(unit_index(table.tag[row]))
            if index in known and table.born[row] <= labels.steps[t].game_loop < table.died[row]:
                np.testing.assert_allclose(known[index], (table.x[row], table.y[row]))


@pytest.fixture(scope="module")
def kairos():
    replay = open_replay(REPLAYS / KAIROS)
    labels = label_players(replay, read_metadata(replay))
    d = replay.initdata["m_syncLobbyState"]["m_gameDescription"]
    return unit_table(replay), labels, (d["m_mapSizeX"], d["m_mapSizeY"])


def test_observations_follow_pysc2s_layers_and_the_fog(kairos):
    table, labels, map_size = kairos
    view = View(map_size)
    first = observe_step(table, labels[1], 1, 1, view)  # loop 8: the start of the game
    minimap, screen = first["feature_minimap"], first["feature_screen"]
    assert minimap.shape == (11, 64, 64) and screen.shape == (27, 64, 64)
    relative = minimap[MINIMAP_FEATURES.player_relative.index]
    # The player's start (its Command Center and SCVs), the neutral minerals, and no
    # enemy: the enemy's base is out of sight.
    assert (relative == 1).any() and (relative == 3).any() and not (relative == 4).any()
    full = observe_step(table, labels[1], 1, 1, View(map_size, full_information=True))
    assert (full["feature_minimap"][MINIMAP_FEATURES.player_relative.index] == 4).any()
    # The camera box on the minimap: 24 x 24 world units at 64/168 pixels per unit,
    # about 9 x 9 pixels.
    assert 64 <= minimap[MINIMAP_FEATURES.camera.index].sum() <= 110
    # Units drawn are visible, and carry PySC2's ids: the Command Center's type.
    types = set(np.unique(minimap[MINIMAP_FEATURES.unit_type.index]).tolist())
    assert stable_unit_ids()["CommandCenter"] in types
    seen = minimap[MINIMAP_FEATURES.visibility_map.index]
    assert set(np.unique(seen).tolist()) == {0, 2} and (seen[relative == 1] == 2).all()
    # The player vector from the first PlayerStats: 50 minerals, 12 of 15 supply.
    np.testing.assert_array_equal(first["player"][:7], [1, 50, 0, 12, 15, 0, 12])
    # Every layer within PySC2's scale.
    for features, layers in ((MINIMAP_FEATURES, minimap), (SCREEN_FEATURES, screen)):
        for f in features:
            assert layers[f.index].min() >= 0 and layers[f.index].max() < f.scale, f.name


def test_selected_units_are_drawn_selected(kairos):
    table, labels, map_size = kairos
    t = next(t for t, s in enumerate(labels[1].selections) if len(s) >= 2)
    o = observe_step(table, labels[1], t, 1, View(map_size))
    assert o["feature_minimap"][MINIMAP_FEATURES.selected.index].any()
    with pytest.raises(ValueError, match="screen_size must be an int in 1..256, got 0"):
        View(map_size, screen_size=0)
