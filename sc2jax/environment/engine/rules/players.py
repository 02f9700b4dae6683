"""The two players of a melee game: the other player's side of the state, and the mirror.

`EnvState` holds the game as one player sees it, the `Owner.SELF` player: its bank,
research, score, camera, explored cells, selection and control groups. On a two-player
map `EnvState.other` (a `Side`) holds the same for the other player, `Owner.ENEMY`, and
`mirror(state)` is the game as that player sees it: the units' owners swapped, these
fields swapped with `other`'s, victory and defeat swapped. `mirror(mirror(s))` is `s`,
so the rules written for `Owner.SELF` (actions, production, research, score,
observations) serve either player. One-player maps have `other=None`.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
from flax import struct

from sc2jax.environment.engine.rules.state import EnvState, Outcome, Owner, Units


@struct.dataclass
class Side:
    """The other player's own fields, as in `EnvState` (there for the player seen).

    Attributes:
      camera, score, score_cumulative, score_by_vital, minerals, vespene, researched,
        collection_rate, explored, last_action, action_result: as `EnvState`'s.
      selected: bool[N] the other player's selection (`Units.selected` is the player's).
      groups: int32[N] its control groups (as `Units.groups`).
      player_id: int32 scalar, its player id (1 or 2); the player seen is the other.
    """

    camera: jax.Array
    score: jax.Array
    score_cumulative: jax.Array
    score_by_vital: jax.Array
    minerals: jax.Array
    vespene: jax.Array
    researched: jax.Array
    collection_rate: jax.Array
    explored: jax.Array
    last_action: jax.Array
    action_result: jax.Array
    selected: jax.Array
    groups: jax.Array
    player_id: jax.Array


SIDE_FIELDS = tuple(f.name for f in dataclasses.fields(Side)
                    if f.name not in ("selected", "groups", "player_id"))
"""The `EnvState` fields each player has its own of."""
assert set(SIDE_FIELDS) <= {f.name for f in dataclasses.fields(EnvState)}


def side_of(state: EnvState, player_id) -> Side:
    """The player's own fields of `state` as a `Side` (its units' selection and groups
    included), with the given player id (int32 scalar)."""
    return Side(**{name: getattr(state, name) for name in SIDE_FIELDS},
                selected=state.units.selected, groups=state.units.groups,
                player_id=jnp.asarray(player_id, jnp.int32))


def swap_owners(units: Units) -> Units:
    """The units with `Owner.SELF` and `Owner.ENEMY` swapped (neutral units stay)."""
    return swap_owners_if(units, True)


def swap_owners_if(units: Units, swap) -> Units:
    """`swap_owners(units)` where bool `swap` (traced or not), else the units."""
    owner = units.owner
    swapped = jnp.where(owner == Owner.SELF, int(Owner.ENEMY), jnp.where(
        owner == Owner.ENEMY, int(Owner.SELF), owner))
    return units.replace(owner=jnp.where(swap, swapped, owner).astype(owner.dtype))


def player_id(state: EnvState):
    """int32: the player id of the player `state` is seen by (1, or 2 when mirrored)."""
    return jnp.int32(1) if state.other is None else 3 - state.other.player_id


def mirror(state: EnvState) -> EnvState:
    """The game as the other player sees it (an involution).

    Raises:
      ValueError: on a one-player state (`state.other` is None).
    """
    other = state.other
    if other is None:
        raise ValueError("mirror needs a two-player state (EnvState.other is None: the map "
                         "has one player)")
    units = swap_owners(state.units).replace(selected=other.selected, groups=other.groups)
    seen = side_of(state, player_id(state))
    outcome = state.outcome
    outcome = jnp.where(outcome == Outcome.VICTORY, int(Outcome.DEFEAT), jnp.where(
        outcome == Outcome.DEFEAT, int(Outcome.VICTORY), outcome)).astype(outcome.dtype)
    return state.replace(units=units, outcome=outcome, other=seen,
                         **{name: getattr(other, name) for name in SIDE_FIELDS})
