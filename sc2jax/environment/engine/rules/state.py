"""The simulator's state: fixed-size unit arrays with an alive mask, and the game around them.

Everything is a pytree of arrays (`flax.struct.dataclass`), so states can be jitted,
vmapped, and compared bit for bit. `N` is the number of unit slots, fixed per map, and
`Q` the number of queued orders a unit can hold.
"""

from __future__ import annotations

import enum
import math

import jax
import jax.numpy as jnp
from flax import struct

from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from sc2jax.environment.interface import observation_tables as tables

# Facing of units created with the editor's default facing (270 degrees).
DEFAULT_FACING = -math.pi / 2

ORDER_QUEUE = 4
BUILD_QUEUE = 8
"""A producer's training queue: 5 units, 8 with a Reactor (`production.queue_room`)."""
NO_TARGET = -1


def slot_rows(tree, rows: slice):
    """The `rows` slots of every array of a per-slot pytree (`Units`, unit-data rows,
    or a single [N, ...] array)."""
    return jax.tree.map(lambda x: x[rows], tree)


def leading_slots(tree, k: int | None):
    """The first k slots of every array of a per-slot pytree; the whole tree for None."""
    return tree if k is None else slot_rows(tree, slice(k))


def slots_in_use(alive):
    """int32: one past the last living slot of bool[N] `alive` (0 with none alive)."""
    return jnp.max(jnp.where(alive, jnp.arange(1, alive.shape[-1] + 1), 0)).astype(jnp.int32)


def open_slots(units) -> jax.Array:
    """bool[N]: the slots a new unit may take: dead ones, but not a resource's. A mined
    out mineral field or a geyser under a Refinery keeps its slot, so that the resources
    stay in the slots they start in (`MiniGame.resource_slots`)."""
    resource = (units.type == UnitType.MINERAL_FIELD) | (units.type == UnitType.VESPENE_GEYSER)
    return ~units.alive & ~resource


def first_slots(mask, count: int):
    """int32[count]: the first `count` slots where bool[N] `mask` holds, ascending; N
    where there are fewer.

    `jnp.nonzero(mask, size=count)` without its scatter: each slot's rank among the
    true ones is compared with 0..count-1 ([count, N]), so that a game loop using it
    can be compiled whole (`devices.compile_small_loops_whole`).
    """
    mask = jnp.asarray(mask, bool)
    n = mask.shape[-1]
    rank = jnp.cumsum(mask, dtype=jnp.int32) - 1
    hit = mask & (rank == jnp.arange(count, dtype=jnp.int32)[:, None])
    return jnp.where(hit.any(axis=-1), jnp.argmax(hit, axis=-1), n).astype(jnp.int32)


def targeted_by(target, num_slots: int):
    """bool[N, M]: [i, j] where int32[N] `target` of unit i is slot j < M (`num_slots`).

    Sums, minima and maxima by target over its rows replace scatters, so that a game
    loop using them can be compiled whole (`devices.compile_small_loops_whole`).
    """
    return jnp.asarray(target)[:, None] == jnp.arange(num_slots, dtype=jnp.int32)


class Order(enum.IntEnum):
    """What a unit is doing. `NONE` is idle."""

    NONE = 0
    MOVE = 1
    ATTACK_MOVE = 2
    ATTACK_UNIT = 3
    PATROL = 4
    HOLD = 5
    GATHER = 6
    RETURN = 7
    BUILD = 8  # Walk to the order's point and place a structure of the order's type.
    CONSTRUCT = 9  # Build the order's target unit, an unfinished structure.
    LAND = 10  # Fly to the order's point and land as the order's type (`liftoff`).


class Owner(enum.IntEnum):
    """Player ids, as in the `player_id` layers (16 is neutral)."""

    NONE = 0
    SELF = 1
    ENEMY = 2
    NEUTRAL = 16


@struct.dataclass
class Units:
    """All unit slots. Every field has leading dimension N.

    Attributes:
      alive: bool[N]; dead or unused slots are False and ignored everywhere.
      type: int32[N] `UnitType`.
      owner: int32[N] `Owner`.
      tag: int32[N] unique per created unit (a wave reset's replacements get new tags).
      pos: float32[N, 2] world position (x, y), y up.
      facing: float32[N] radians, 0 along +x.
      health, shields, energy: float32[N].
      cooldown: float32[N] loops until the weapon can fire.
      orders: int32[N, Q] `Order` queue; slot 0 is current.
      order_pos: float32[N, Q, 2] target points.
      order_unit: int32[N, Q] target unit slots, or -1.
      order_type: int32[N, Q] the `UnitType` a BUILD order places or a LAND order lands
        as, else 0.
      patrol_origin: float32[N, 2] where the current patrol leg started.
      target: int32[N] the unit being engaged (acquired or ordered), or -1.
      selected: bool[N].
      groups: int32[N] control-group membership bitmask (bit g for group g).
      cargo: float32[N] resources a worker carries.
      work: float32[N] loops of harvesting left (a worker mining), else 0.
      contents: float32[N] resources left in a mineral field or geyser.
      home: int32[N] the resource a worker harvests (it returns there), or -1.
      gas: bool[N] a worker's cargo is vespene (else minerals).
      progress: float32[N] loops of construction done; a unit is complete once this
        reaches its type's `build_time` (units the map creates start complete).
      queue: int32[N, B] a producer's training queue of `UnitType`s, 0 for empty.
      queue_work: float32[N, B] loops of training done on each queued unit (the first,
        and with a Reactor the first two, train at once).
      rally: float32[N, 2] a producer's rally point.
      rally_unit: int32[N] the unit the rally targets (new workers gather from a
        resource), or -1.
      rallied: bool[N] a rally is set.
      addon: int32[N] a producer's add-on (Tech Lab or Reactor) slot, or -1; valid
        while that slot holds a living add-on beside it (`production.addon_kinds`).
      stim: float32[N] loops a Stimpack lasts (`research`), else 0.
      slow: float32[N] loops a Concussive Shells slow lasts, else 0.
      life: float32[N] loops a timed unit (the MULE) has left to live, else 0.
    """

    alive: jax.Array
    type: jax.Array
    owner: jax.Array
    tag: jax.Array
    pos: jax.Array
    facing: jax.Array
    health: jax.Array
    shields: jax.Array
    energy: jax.Array
    cooldown: jax.Array
    orders: jax.Array
    order_pos: jax.Array
    order_unit: jax.Array
    order_type: jax.Array
    patrol_origin: jax.Array
    target: jax.Array
    selected: jax.Array
    groups: jax.Array
    cargo: jax.Array
    work: jax.Array
    contents: jax.Array
    home: jax.Array
    gas: jax.Array
    progress: jax.Array
    queue: jax.Array
    queue_work: jax.Array
    rally: jax.Array
    rally_unit: jax.Array
    rallied: jax.Array
    addon: jax.Array
    stim: jax.Array
    slow: jax.Array
    life: jax.Array

    @property
    def num_slots(self) -> int:
        return self.alive.shape[-1]

    @property
    def complete(self) -> jax.Array:
        """bool[N]: living units whose construction is finished."""
        return self.alive & (self.progress >= jnp.asarray(UNIT_DATA.build_time)[self.type])

    @property
    def idle_workers(self) -> jax.Array:
        """bool[N]: the player's SCVs without orders."""
        return (self.alive & (self.owner == Owner.SELF) & (self.type == UnitType.SCV)
                & (self.orders[:, 0] == Order.NONE))

    @classmethod
    def empty(cls, num_slots: int) -> Units:
        """Returns N empty slots."""
        n, q, b = num_slots, ORDER_QUEUE, BUILD_QUEUE
        f = lambda *s: jnp.zeros(s, jnp.float32)  # noqa: E731
        i = lambda *s: jnp.zeros(s, jnp.int32)  # noqa: E731
        return cls(
            alive=jnp.zeros(n, bool), type=i(n), owner=i(n), tag=i(n), pos=f(n, 2),
            facing=f(n), health=f(n), shields=f(n), energy=f(n), cooldown=f(n),
            orders=i(n, q), order_pos=f(n, q, 2),
            order_unit=jnp.full((n, q), NO_TARGET, jnp.int32), order_type=i(n, q),
            patrol_origin=f(n, 2), target=jnp.full((n,), NO_TARGET, jnp.int32),
            selected=jnp.zeros(n, bool), groups=i(n), cargo=f(n), work=f(n), contents=f(n),
            home=jnp.full((n,), NO_TARGET, jnp.int32), gas=jnp.zeros(n, bool), progress=f(n),
            queue=i(n, b), queue_work=f(n, b), rally=f(n, 2),
            rally_unit=jnp.full((n,), NO_TARGET, jnp.int32), rallied=jnp.zeros(n, bool),
            addon=jnp.full((n,), NO_TARGET, jnp.int32), stim=f(n), slow=f(n), life=f(n))


@struct.dataclass
class EnvState:
    """The whole game state of one environment.

    Attributes:
      units: the unit slots.
      camera: float32[2] world point at the centre of the screen.
      game_loop: int32 scalar.
      score: int32 scalar, the curriculum score (`score_cumulative[0]`).
      score_cumulative: int32[13] the rest of `score_cumulative` (index 0 mirrors `score`).
      score_by_vital: float32[3, 3] `score_by_vital` (damage dealt, taken, healed).
      minerals, vespene: int32 scalars.
      researched: bool[R] the player's research done (`research.Research`).
      collection_rate: float32[2] minerals and vespene collected per real minute at
        Faster speed, a moving average (`score_cumulative`'s collection rates).
      explored: bool[map_h, map_w] cells the player has ever seen, row 0 at the top (as
        the `MapGeometry` grids).
      next_tag: int32 scalar, the next unit tag.
      last_action: int32 scalar, the function id executed last step, or -1.
      action_result: int32 scalar, the `ActionResult` of a failed action, or 0.
      outcome: int32 scalar, 0 while running, then 1 victory, 2 defeat, 3 tie.
      episode_step: int32 scalar, agent steps since the episode started.
      map_state: the map script's own state (a pytree).
      key: the RNG key for everything random in the game.
      other: None on one-player maps; on two-player maps the other player's own fields
        (`players.Side`: its bank, research, score, camera, selection...).
    """

    units: Units
    camera: jax.Array
    game_loop: jax.Array
    score: jax.Array
    score_cumulative: jax.Array
    score_by_vital: jax.Array
    minerals: jax.Array
    vespene: jax.Array
    researched: jax.Array
    collection_rate: jax.Array
    explored: jax.Array
    next_tag: jax.Array
    last_action: jax.Array
    action_result: jax.Array
    outcome: jax.Array
    episode_step: jax.Array
    map_state: object
    key: jax.Array
    other: object = None


def _new_units(units: Units, k: int, unit_type, owner, positions, tags, selected) -> dict:
    """Field -> the values of k new units (complete, at full health and starting energy,
    with no orders), each broadcast to [k, ...] (`place`, `place_where`)."""
    types = jnp.broadcast_to(jnp.asarray(unit_type, jnp.int32), (k,))
    data = UNIT_DATA
    values = dict(
        alive=True, type=types, owner=jnp.asarray(owner, jnp.int32), tag=tags,
        pos=positions, facing=DEFAULT_FACING, health=jnp.asarray(data.max_health)[types],
        shields=jnp.asarray(data.max_shields)[types],
        energy=jnp.asarray(data.start_energy)[types], cooldown=0.0,
        orders=Order.NONE, order_unit=NO_TARGET, target=NO_TARGET, selected=selected,
        groups=0, cargo=0.0, work=0.0, contents=jnp.asarray(data.contents)[types],
        home=NO_TARGET, order_type=0, gas=False,
        progress=jnp.asarray(data.build_time)[types], queue=0, queue_work=0.0,
        rally_unit=NO_TARGET, rallied=False, addon=NO_TARGET, stim=0.0, slow=0.0,
        life=0.0)
    fields = {name: getattr(units, name) for name in values}
    return {name: jnp.broadcast_to(jnp.asarray(value, fields[name].dtype),
                                   (k,) + fields[name].shape[1:])
            for name, value in values.items()}


def place(units: Units, slots, unit_type, owner, positions, next_tag, selected=False):
    """Creates units in the given slots, complete, at full health, with no orders.

    Args:
      units: the units.
      slots: int32[k] slots to fill (slots >= N are ignored).
      unit_type: `UnitType` (int or int32[k]).
      owner: `Owner` (int or int32[k]).
      positions: float32[k, 2].
      next_tag: int32 first tag to hand out.
      selected: whether the new units are selected (bool or bool[k]).

    Returns:
      (units, next_tag).
    """
    slots = jnp.asarray(slots)
    k = slots.shape[0]
    tags = next_tag + jnp.arange(k, dtype=jnp.int32)
    new = _new_units(units, k, unit_type, owner, positions, tags, selected)
    units = units.replace(**{name: getattr(units, name).at[slots].set(value, mode="drop")
                             for name, value in new.items()})
    return units, next_tag + k


def place_where(units: Units, where, unit_type, owner, positions, tags, selected=False):
    """`place` in the slots where `where` (bool[N]) holds, each slot given its own
    values: a select per field, not a scatter, so that a game loop that creates units
    can be compiled whole (`devices.compile_small_loops_whole`).

    Args:
      units: the units.
      where: bool[N] the slots to fill.
      unit_type: `UnitType` (int or int32[N]).
      owner: `Owner` (int or int32[N]).
      positions: float32[N, 2].
      tags: int32[N].
      selected: bool or bool[N].

    Returns:
      The units.
    """
    n = units.num_slots
    where = jnp.asarray(where, bool)
    new = _new_units(units, n, unit_type, owner, positions, tags, selected)
    return units.replace(**{
        name: jnp.where(where.reshape((n,) + (1,) * (value.ndim - 1)), value,
                        getattr(units, name))
        for name, value in new.items()})


class Outcome(enum.IntEnum):
    RUNNING = 0
    VICTORY = 1
    DEFEAT = 2
    TIE = 3


NUM_SCORE_CUMULATIVE = len(tables.ScoreCumulative)
