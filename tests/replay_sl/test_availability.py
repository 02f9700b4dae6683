"""available_actions of replay steps: the UI functions' conditions and the command cards
learned from the training games."""

import pathlib

import numpy as np
import pytest

from sc2jax.environment.interface.functions import FUNCTIONS, NUM_FUNCTIONS
from sc2jax.environment.interface.observation_tables import Player
from sc2jax.replay_sl import label_players, open_replay, read_metadata, unit_table
from sc2jax.replay_sl.availability import (
    available_actions,
    cards_from_json,
    load_cards,
)
from sc2jax.replay_sl.observations import View, observe_steps
from sc2jax.replay_sl.units import UnitsAt, stable_unit_ids

IDS = stable_unit_ids()
REPLAYS = pathlib.Path(__file__).parents[3] / "shared" / "replays"
HELD_OUT = REPLAYS / "nation_wars/0276_WorldofSleepers.SC2Replay"  # in the test split


def test_cards_keep_the_functions_used_often_enough():
    uses = {"Marine": {"Attack_screen": 990, "Train_Battlecruiser_quick": 1, "Stop_quick": 9}}
    table = cards_from_json(uses, min_share=0.005).table
    marine = np.flatnonzero(table[IDS["Marine"]])
    assert [FUNCTIONS[int(f)].name for f in marine] == ["Attack_screen", "Stop_quick"]
    assert table.sum() == 2
    with pytest.raises(ValueError, match="unknown unit type 'Marin'"):
        cards_from_json({"Marin": {"Attack_screen": 1}})
    with pytest.raises(ValueError, match="unknown function 'Attack_scren' on 'Marine'"):
        cards_from_json({"Marine": {"Attack_scren": 1}})
    with pytest.raises(ValueError, match=r"min_share must be in \[0, 1\), got 1"):
        cards_from_json(uses, min_share=1)


def test_the_mask_unites_a_steps_selection_and_the_next_ones():
    cards = cards_from_json({"SCV": {"Build_SupplyDepot_screen": 5, "Harvest_Gather_screen": 5},
                             "Barracks": {"Train_Marine_quick": 3}})
    # Units: two SCVs and a Barracks of player 1, a Barracks of player 2. Three steps:
    # both SCVs selected; nothing; the enemy's Barracks (not the player's: no card).
    types = np.asarray([IDS["SCV"], IDS["SCV"], IDS["Barracks"], IDS["Barracks"]])
    at = UnitsAt(np.ones((3, 4), bool), np.tile([1, 1, 1, 2], (3, 1)), np.tile(types, (3, 1)))
    selected = np.asarray([[1, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]], bool)
    player = np.zeros((3, len(Player)), np.int32)
    player[1, Player.larva_count] = 2
    mask = available_actions(at, selected, player, 1, cards)
    on = lambda t: {FUNCTIONS[int(f)].name for f in np.flatnonzero(mask[t])}  # noqa: E731
    always = {"no_op", "move_camera", "select_point", "select_rect", "select_control_group"}
    assert on(0) == always | {"select_unit", "Build_SupplyDepot_screen", "Harvest_Gather_screen"}
    assert on(1) == always | {"select_larva"}
    assert on(2) == always  # The last step is its own next.
    assert mask.shape == (3, NUM_FUNCTIONS)


@pytest.mark.skipif(not HELD_OUT.exists(), reason="the replays are not there")
def test_held_out_labels_fall_inside_the_mask():
    # A game of the test split (never read to learn the shipped cards): most of its
    # labels are allowed by the mask built from the selection and the learned cards.
    replay = open_replay(HELD_OUT)
    labels = label_players(replay, read_metadata(replay))
    table = unit_table(replay)
    d = replay.initdata["m_syncLobbyState"]["m_gameDescription"]
    view, cards = View((d["m_mapSizeX"], d["m_mapSizeY"]), 16, 16), load_cards()
    inside, sizes = [], []
    for player_id, label in labels.items():
        steps = range(len(label.steps))
        mask = observe_steps(table, label, player_id, view, steps, cards)["available_actions_mask"]
        functions = np.asarray([s.call.function for s in label.steps])
        inside.append(mask[np.arange(len(functions)), functions])
        sizes.append(mask.sum(axis=1))
    inside, sizes = np.concatenate(inside), np.concatenate(sizes)
    assert inside.mean() > 0.97, inside.mean()
    assert 5 <= sizes.min() and np.median(sizes) < 80, (sizes.min(), np.median(sizes))
