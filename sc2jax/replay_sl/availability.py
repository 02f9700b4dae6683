"""`available_actions` for a replay's agent steps, without the game.

PySC2 makes a function available (reference: `Features.available_actions`) when it is a
UI function whose condition holds, or an ability on the command card of the selected
units. A replay records neither the command cards nor the UI, so both are approximated:

- `no_op`, `move_camera`, `select_point`, `select_rect`, `select_control_group`: always;
- `select_unit`: more than one unit selected;
- `select_idle_worker`, `select_army`, `select_warp_gates`, `select_larva`: by the
  `player` vector's counts (`observations.player_vectors`: idle workers estimated,
  army food from PlayerStats, warp gates and larvae counted in the unit table);
- every other function (abilities, and `unload` and `build_queue`, which the labeller
  never emits): on the `CommandCards` of a selected unit type of the player.

The command cards are learned from replays of the training split (`learn_cards`): a
function is on a unit type's card when it makes at least `MIN_SHARE` of the uses with
only units of that type selected (the tracked selection is sometimes wrong, which puts a
few stray functions on many types). The package ships the uses in the 484 training games of
`../shared/replays` (`scripts/command_cards.py`); a dataset can be converted with cards
learned from other replays. Cards learned this way miss buttons nobody pressed and
ignore requirements (resources, tech, cooldowns); docs/replays.md measures how often a
held-out label falls outside the mask. As in the paper, the mask of a step is the union
over its game loops: here, over the selections at its first loop and at the next
step's.
"""

from __future__ import annotations

import collections
import dataclasses
import importlib.resources
import json
import os

import numpy as np

from sc2jax.environment.interface.features import UNIT_TYPE_SCALE
from sc2jax.environment.interface.functions import ALWAYS, FUNCTIONS, NUM_FUNCTIONS
from sc2jax.environment.interface.observation_tables import Player
from sc2jax.replay_sl.actions import ActionLabels
from sc2jax.replay_sl.units import UnitsAt, UnitTable, stable_unit_ids, stable_unit_names

FIRST_CARD_FUNCTION = FUNCTIONS.unload.id
"""Functions from this id on are decided by the command cards (PySC2's ids 10 and up)."""
MIN_SHARE = 0.002
"""A function is on a type's card when it makes at least this share of its uses."""
_BY_COUNT = {"select_idle_worker": Player.idle_worker_count, "select_army": Player.food_army,
             "select_warp_gates": Player.warp_gate_count, "select_larva": Player.larva_count}


@dataclasses.dataclass(frozen=True)
class CommandCards:
    """The functions on each unit type's command card.

    Attributes:
      table: bool [UNIT_TYPE_SCALE, NUM_FUNCTIONS]: table[unit type, function id].
    """

    table: np.ndarray


def counts_to_json(counts: collections.Counter) -> dict:
    """{unit type name: {function name: uses}} from `learn_cards`' counts."""
    names = stable_unit_names()
    out: dict[str, dict[str, int]] = {}
    for (unit_type, function), n in sorted(counts.items()):
        out.setdefault(names.get(unit_type, str(unit_type)), {})[FUNCTIONS[function].name] = n
    return out


def cards_from_json(data: dict, *, min_share: float = MIN_SHARE) -> CommandCards:
    """The cards of `counts_to_json`'s uses: a function is on a type's card when it makes
    at least `min_share` of the type's uses (selection errors put a few stray functions
    on many types).

    Raises:
      ValueError: for an unknown unit type or function name, or a bad `min_share`.
    """
    if not 0 <= min_share < 1:
        raise ValueError(f"min_share must be in [0, 1), got {min_share!r}")
    ids = stable_unit_ids()
    table = np.zeros((UNIT_TYPE_SCALE, NUM_FUNCTIONS), bool)
    for unit, uses in data.items():
        unit_type = ids.get(unit, int(unit) if unit.isdigit() else None)
        if unit_type is None or not 0 <= unit_type < UNIT_TYPE_SCALE:
            raise ValueError(f"unknown unit type {unit!r} in the command cards")
        total = sum(uses.values())
        for name, n in uses.items():
            if name not in FUNCTIONS:
                raise ValueError(f"unknown function {name!r} on {unit!r}'s command card")
            table[unit_type, FUNCTIONS[name].id] = n >= min_share * total
    return CommandCards(table)


def load_cards(path: str | os.PathLike | None = None, *,
               min_share: float = MIN_SHARE) -> CommandCards:
    """The command cards from a JSON file of uses (`counts_to_json`), by default the
    ones the package ships (`cards_from_json`)."""
    if path is None:
        text = (importlib.resources.files("sc2jax.replay_sl") / "data"
                / "command_cards.json").read_text(encoding="utf-8")
    else:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    return cards_from_json(json.loads(text), min_share=min_share)


def learn_cards(counts: collections.Counter, table: UnitTable, labels: ActionLabels,
                player_id: int) -> None:
    """Adds to `counts[(unit type, function id)]` every card function the player used
    with only units of one type selected."""
    steps = [t for t, step in enumerate(labels.steps)
             if step.call.function >= FIRST_CARD_FUNCTION and labels.selections[t]]
    if not steps:
        return
    at = table.at([labels.steps[t].game_loop for t in steps])
    for n, t in enumerate(steps):
        rows = np.isin(table.tag, np.asarray(labels.selections[t], np.int64))
        rows &= at.alive[n] & (at.owner[n] == player_id)
        types = np.unique(at.unit_type[n][rows])
        if len(types) == 1:
            counts[(int(types[0]), int(labels.steps[t].call.function))] += 1


_ALWAYS_MASK = np.isin(np.arange(NUM_FUNCTIONS), [FUNCTIONS[name].id for name in ALWAYS])


def available_actions(at: UnitsAt, selected: np.ndarray, player: np.ndarray, player_id: int,
                      cards: CommandCards) -> np.ndarray:
    """bool [T, NUM_FUNCTIONS]: the functions available at T consecutive agent steps of a
    player, each the union over its own selection and the next step's.

    Args:
      at: the units' state at the steps' first loops, [T', U] with T' = T, or T + 1 to
        include the step after the last (the last step is otherwise its own next).
      selected: bool [T', U], the player's selected units at those loops.
      player: int32 [T, 11], the steps' `player` vectors (`observations.player_vectors`).
      player_id: 1-based.
      cards: the command cards.
    """
    steps = len(player)
    own = selected & at.alive & (at.owner == player_id)
    by_selection = np.zeros((len(own), NUM_FUNCTIONS), bool)
    by_selection[:, FUNCTIONS.select_unit.id] = selected.sum(axis=1) > 1
    t, u = np.nonzero(own)
    types = at.unit_type[t, u]
    step, unit_type = np.unique(np.stack([t, np.where(types < UNIT_TYPE_SCALE, types, 0)]),
                                axis=1)  # Sorted by step.
    if len(step):
        first = np.flatnonzero(np.r_[True, step[1:] != step[:-1]])
        card = np.logical_or.reduceat(cards.table[unit_type], first, axis=0)
        by_selection[step[first], FIRST_CARD_FUNCTION:] = card[:, FIRST_CARD_FUNCTION:]
    following = np.concatenate([by_selection[1:steps + 1],
                                by_selection[len(own) - 1:]])[:steps]
    mask = by_selection[:steps] | following | _ALWAYS_MASK[None, :]
    for name, field in _BY_COUNT.items():
        mask[:, FUNCTIONS[name].id] = player[:, field] > 0
    return mask
