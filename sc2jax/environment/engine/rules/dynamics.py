"""One game loop of unit behaviour: targets, movement, collisions, attacks and deaths.

All per-unit logic is vectorised over the N slots, and pairs of units over [N, N] arrays;
simultaneous damage is summed over the pairs. On a map whose two sides hold separate
slot ranges (`team_split`), combat looks only at the pairs across the split: blocks of
[S, N - S] and [N - S, S] instead of [N, N]. Orders (`state.Order`) are executed as the game
does for the mini-games:

- idle units, attack-moving and patrolling units acquire the nearest enemy within
  their acquisition range and chase it while it stays within sight; a unit hit while
  idle turns on its attacker;
- holding units fire at enemies in weapon range and never move;
- moving units ignore enemies; attack-unit orders chase their target until it dies.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.rules import harvest, research
from sc2jax.environment.engine.rules.geometry import distances, squared_length
from sc2jax.environment.engine.rules.state import (
    NO_TARGET,
    Order,
    Owner,
    Units,
    leading_slots,
    slot_rows,
    targeted_by,
)
from sc2jax.environment.engine.rules.units import UNIT_DATA, Attribute, Targets
from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.engine.xla.fusion import first_argmin, mask_once
from sc2jax.environment.engine.xla.lazy import lazy_where

# A move order ends within this distance of its goal, or when the unit is blocked
# (it moved less than STUCK_FRACTION of its speed) within BLOCKED_ARRIVAL of the goal.
ARRIVAL = 1e-3
BLOCKED_ARRIVAL = 1.0
STUCK_FRACTION = 0.2


BY_PLAYER = (Owner.SELF, Owner.ENEMY)
"""The players of `LoopEvents`' per-player sums, in order."""


class LoopEvents(NamedTuple):
    """What happened during one loop.

    Attributes:
      died: bool[N] units that died this loop (they are no longer alive).
      damage_dealt: float32[2], damage dealt by each player's units (`Owner.SELF`'s,
        then `Owner.ENEMY`'s: `BY_PLAYER`).
      damage_taken: float32[2], damage taken by each player's units.
      minerals: float32[2], minerals each player's workers deposited.
      vespene: float32[2], vespene each player's workers deposited.
      created: bool[N] slots where a unit was trained or a structure placed (filled in
        by `production.production_loop`; all False from `game_loop`).
      heading: float32[N, 2] the way each unit turned to this loop (its movement, or
        the target it attacks), (0, 0) where it did not turn (`facing_of`).
    """

    died: jax.Array
    damage_dealt: jax.Array
    damage_taken: jax.Array
    minerals: jax.Array
    vespene: jax.Array
    created: jax.Array
    heading: jax.Array

    @classmethod
    def none(cls, num_slots: int, died=None) -> LoopEvents:
        """A loop where nothing happened (except the deaths in `died`, bool[N])."""
        nothing = jnp.zeros(num_slots, bool)
        zero = jnp.zeros(len(BY_PLAYER), jnp.float32)
        return cls(died=nothing if died is None else jnp.asarray(died), damage_dealt=zero,
                   damage_taken=zero, minerals=zero, vespene=zero, created=nothing,
                   heading=jnp.zeros((num_slots, 2), jnp.float32))


def turned(heading):
    """bool[N]: the units that turned, by their float32[N, 2] `heading` (`LoopEvents`):
    (0, 0) is no turn."""
    return jnp.any(heading != 0, axis=-1)


def facing_of(heading, facing):
    """float32[N]: the facing (radians) of the units that turned to `heading`
    (float32[N, 2], (0, 0) for those that did not, `LoopEvents.heading`), else `facing`.

    An arctangent per unit, which XLA's CPU backend does not vectorise (10 ns each):
    `Simulator` sets facing once per agent step from each unit's last turn, not in every
    game loop (`game_loop(face=False)`).
    """
    return jnp.where(turned(heading), jnp.arctan2(heading[:, 1], heading[:, 0]), facing)


def _data(types):
    """Per-unit stats for a type array."""
    return jax.tree_util.tree_map(lambda column: jnp.asarray(column)[types], UNIT_DATA)


def hostile(a, b):
    """bool[R, C]: unit i of owners a (int32[R]) and unit j of owners b (int32[C]) are
    enemies (the player against player 2)."""
    a, b = a[:, None], b[None, :]
    return ((a == Owner.SELF) & (b == Owner.ENEMY)) | ((a == Owner.ENEMY) & (b == Owner.SELF))


class PairBlock(NamedTuple):
    """The pairs of two slot ranges, `rows` (R slots) against `cols` (C slots), at the
    loop's start.

    Attributes:
      rows, cols: the slot ranges.
      dist: float32[R, C] centre distances.
      gap: float32[R, C] edge gaps (the distance less both radii).
      enemy: bool[R, C] both alive and hostile.
    """

    rows: slice
    cols: slice
    dist: jax.Array
    gap: jax.Array
    enemy: jax.Array

    def column(self, slots):
        """int32[R]: the column of each row's slot in `slots` (int32[R]), clipped into
        `cols` (rows with a slot outside `cols` get another column)."""
        return jnp.clip(slots - self.cols.start, 0, self.gap.shape[1] - 1)

    def at(self, slots):
        """float32[R]: each row's gap to its slot in `slots` (int32[R] in `cols`; rows
        with a slot outside `cols` get another column's gap)."""
        return self.gap[jnp.arange(self.gap.shape[0]), self.column(slots)]


def layer(flying):
    """int32[...]: the `Targets` flag a weapon needs to hit each unit (bool[...] flying):
    AIR for flying units, GROUND for the others."""
    return jnp.where(flying, int(Targets.AIR), int(Targets.GROUND))


def pair_blocks(units: Units, data, team_split: int | None,
                air: bool = False, static_slots: int = 0) -> list[PairBlock]:
    """The pairs among which combat happens: all [N, N] pairs, or, where one side's
    units are only ever in the first `team_split` slots and the other side's only in
    the rest, the two blocks across the split (the rows of the two together are all N
    slots, in order). With `static_slots` (static) S, the pairs among the slots from S
    on: the first S hold only resources, which neither fight nor can be fought
    (`MiniGame.resource_slots`). With `air` (static), a row's enemies are only the
    columns its weapon can hit (`targets`)."""
    n = units.num_slots
    if team_split is None:
        spans = [(slice(static_slots, n), slice(static_slots, n))]
    else:
        spans = [(slice(0, team_split), slice(team_split, n)),
                 (slice(team_split, n), slice(0, team_split))]
    blocks = []
    for rows, cols in spans:
        dist = distances(units.pos[rows], units.pos[cols])
        gap = dist - data.radius[rows, None] - data.radius[None, cols]
        enemy = (hostile(units.owner[rows], units.owner[cols]) & units.alive[rows, None]
                 & units.alive[None, cols])
        if air:
            enemy = enemy & ((data.targets[rows, None] & layer(data.flying[None, cols])) > 0)
        blocks.append(PairBlock(rows, cols, dist, gap, enemy))
    return blocks


def hits_layer(data, target_type):
    """bool[N]: whether each unit's weapon (its `UNIT_DATA` rows) can hit a unit of
    `target_type` (int32[N])."""
    return (data.targets & layer(jnp.asarray(UNIT_DATA.flying)[target_type])) > 0


def _static_fill(parts: list, first: int, fill) -> list:
    """`parts` after `fill` for the `first` static slots the blocks leave out."""
    if not first:
        return parts
    head = parts[0]
    return [jnp.full((first, *head.shape[1:]), fill, head.dtype), *parts]


def _rows(blocks: list[PairBlock], per_block, fill=0):
    """[N, ...]: `per_block(block)` ([R, ...] for each block's rows) in slot order;
    `fill` in the static slots before the blocks (`pair_blocks`)."""
    parts = _static_fill([per_block(block) for block in blocks], blocks[0].rows.start, fill)
    return parts[0] if len(parts) == 1 else jnp.concatenate(parts)


def _cols(blocks: list[PairBlock], parts: list, fill=0):
    """[N, ...]: `parts` ([C, ...] for each block's columns, in the blocks' order) in slot
    order; `fill` in the static slots before the blocks (`pair_blocks`)."""
    order = sorted(range(len(blocks)), key=lambda i: blocks[i].cols.start)
    parts = _static_fill([parts[i] for i in order], blocks[order[0]].cols.start, fill)
    return parts[0] if len(parts) == 1 else jnp.concatenate(parts)


def _hit_by(block: PairBlock, target):
    """bool[R, C]: whether each row's `target` (int32[N], in its block's columns where it
    matters) is each column."""
    return targeted_by(block.column(target[block.rows]), block.gap.shape[1])


def _fold_rows(op, x):
    """[C]: the rows of x ([R, C]) combined by `op` (jnp.add, jnp.maximum), one row at a
    time: elementwise, where a reduction over the rows of a block's [B, R, C] pairs under
    `vmap` goes to a library reduction on XLA's CPU backend. Sums of damage are exact
    in any order (halves of hit points)."""
    out = x[0]
    for row in range(1, x.shape[0]):
        out = op(out, x[row])
    return out


def _cooldown_jitter(key, size: int):
    """float32[size]: each weapon's cooldown jitter, uniform in {-1, 0, 1, 2} loops.

    The values of `jax.random.randint(key, (size,), -1, 3)`, drawn once: randint draws
    two words of bits and, for a span of 4, uses only the second's low bits; XLA does
    not always drop the unused draw, a loop of its own per game loop (docs/benchmarks.md).
    The hash is `threefry`'s, fused with the rest of the loop.
    """
    _, low = threefry.split(key)
    return (threefry.bits(low, (size,)) & 3).astype(jnp.float32) - 1.0


# The fewest unit slots on which `_skip_unless` skips its computation when unneeded.
SKIP_SLOTS = 8


def _skip_unless(pred, compute, operand, otherwise, num_slots: int):
    """`compute(operand)`, which is `otherwise` where `pred` (bool scalar) is False:
    skipped then, on maps of `SKIP_SLOTS` or more slots.

    Most game loops end no unit's order and see no unit fire. The skip is a
    `lazy_where`: a `cond` unbatched and under `vmap` of fewer than 32 environments; a
    larger batch needs `compute` on most loops, and computes it always. Side by side at
    one environment (docs/benchmarks.md), the order queue's pops: FindAndDefeatZerglings
    1.035x, CollectMineralsAndGas 1.075x; the end of arrived orders after them 1.034x
    more; all three skips (with the strikes, `_strikes`) against none:
    FindAndDefeatZerglings 1.137x, DefeatRoaches 1.082x, DefeatZerglingsAndBanelings
    1.129x, the same at 64 environments. On MoveToBeacon's 2 slots the `cond` cost more
    than the pop (0.985x), so small maps have none.
    """
    if num_slots < SKIP_SLOTS:
        return compute(operand)
    return lazy_where(pred, compute, operand, otherwise, large_batches="always")


def _unless_none(done, update, units: Units) -> Units:
    """`update(units, done)` (bool[N] `done`), which leaves units where `done` is False as
    they are, skipped when none is (`_skip_unless`)."""
    return _skip_unless(jnp.any(done), lambda args: update(*args), (units, done), units,
                        units.num_slots)


def pop_order(units: Units, done) -> Units:
    """Advances the order queue of units where `done` (bool[N]) holds."""
    return _unless_none(done, _shift_orders, units)


def _shift_orders(units: Units, done) -> Units:
    """`pop_order`, computed for every unit."""
    done = mask_once(done)  # Read by every field of the queue.
    shift = lambda x, fill: jnp.where(  # noqa: E731
        done.reshape((-1,) + (1,) * (x.ndim - 1)),
        jnp.concatenate([x[:, 1:], jnp.full_like(x[:, :1], fill)], axis=1), x)
    orders = shift(units.orders, Order.NONE)
    starts_patrol = done & (orders[:, 0] == Order.PATROL)
    return units.replace(
        orders=orders,
        order_pos=shift(units.order_pos, 0.0),
        order_unit=shift(units.order_unit, NO_TARGET),
        order_type=shift(units.order_type, 0),
        patrol_origin=jnp.where(starts_patrol[:, None], units.pos, units.patrol_origin),
        target=jnp.where(done, NO_TARGET, units.target))


def _select_targets(units: Units, data, block: PairBlock):
    """Returns int32[R] the unit each slot of the block's rows engages this loop (one of
    its columns), or -1."""
    units, data = slot_rows(units, block.rows), slot_rows(data, block.rows)
    gap, enemy = block.gap, block.enemy
    order = units.orders[:, 0]
    has_weapon = data.damage > 0
    scan = jnp.where(order == Order.HOLD, data.range, jnp.maximum(data.acquire, data.range))
    scans = has_weapon & ((order == Order.NONE) | (order == Order.ATTACK_MOVE)
                          | (order == Order.PATROL) | (order == Order.HOLD))
    # Keep the current target while it stays an enemy within sight (weapon range if
    # holding), unless it is out of weapon range and another enemy is in range.
    keep_range = jnp.where(order == Order.HOLD, data.range, data.sight)
    current = units.target
    first, num_cols = block.cols.start, gap.shape[1]
    local = block.column(current)
    rows = jnp.arange(gap.shape[0])
    current_gap = gap[rows, local]
    other_in_range = (enemy & (gap <= data.range[:, None])).any(axis=1)
    keep = (scans & (current >= first) & (current < first + num_cols) & enemy[rows, local]
            & (current_gap <= keep_range) & ~(other_in_range & (current_gap > data.range)))
    candidate = enemy & (gap <= scan[:, None])
    nearest = first + first_argmin(jnp.where(candidate, gap, jnp.inf))
    acquired = jnp.where(keep, current, jnp.where(candidate.any(axis=1), nearest, NO_TARGET))
    auto = jnp.where(scans, acquired, NO_TARGET)
    ordered = units.order_unit[:, 0]
    return jnp.where(order == Order.ATTACK_UNIT, ordered, auto)


def game_loop(units: Units, key, playable, bursts: bool = False, workers: bool = False,
              combat: bool = True, colliders: int | None = None,
              field_slots: int | None = None,
              team_split: int | None = None,
              static_slots: int | None = None,
              jitter_slots: int | None = None,
              sized: bool = False, face: bool = True,
              air: bool = False, researched=None) -> tuple[Units, LoopEvents]:
    """Advances all units by one game loop.

    Args:
      units: the unit slots.
      key: RNG key for weapon-cooldown jitter.
      playable: (x0, y0, x1, y1), the area units are kept inside.
      bursts: (static) whether the map has units with a suicide splash attack (`burst`
        in the unit data); maps without them skip its cost.
      workers: (static) whether the map has workers that harvest (`harvest`).
      combat: (static) whether the map has enemies; maps without them skip targeting
        and attacks.
      colliders: (static) None, or the number of leading slots that can hold units that
        collide (`MiniGame.collider_slots`); collisions are resolved among those alone.
      field_slots: (static) None, or the number of leading slots that can hold mineral
        fields (`MiniGame.field_slots`); workers look for free fields among those alone.
      team_split: (static) None, or S where one side's units are only ever in the
        first S slots and the other side's only in the rest (`MiniGame.team_split`); combat
        then looks at the pairs across S alone (`pair_blocks`).
      static_slots: (static) None, or S where the first S slots hold only resources
        (`MiniGame.resource_slots`): combat looks at the pairs among the other slots
        alone, and only those slots are pushed in collisions (resources still block).
      jitter_slots: (static) None, or the map's slot count where `units` are its leading
        slots (`Simulator`'s views): the weapon jitter is drawn for that many slots and
        cut, so that a slot's draw does not depend on how many slots run.
      sized: (static) whether the map runs on several slot counts (`MiniGame.slot_sizes`):
        the collision distances then use `hypot`, whose last bit XLA computes alike for
        every count (`_resolve_collisions`).
      face: (static) set the units' facing; False leaves it, for a caller that sets it
        from the events' `heading` after several loops (`facing_of`).
      air: (static) whether the map has flying units: a weapon then hits only what its
        `targets` allow (a Viking in the air only air units, a Siege Tank only ground
        ones), where maps without them skip the check.
      researched: None, or the players' research (bool[R], or bool[2, R] on two-player
        maps: `research.has`): the upgrades, stims and slows then apply, where maps
        without research skip them.

    Returns:
      The new units and the loop's events.
    """
    n = units.num_slots
    data = _data(units.type)
    if researched is not None:
        data = research.unit_rows(data, units, researched)
    alive = units.alive
    pos = units.pos

    if combat:  # Pair distances; maps without enemies need none.
        blocks = pair_blocks(units, data, team_split, air, static_slots or 0)

    # Attack-unit orders whose target is gone are complete (only an enemy under the
    # cursor gives one, so maps without enemies have none).
    if combat:
        ordered = units.order_unit[:, 0]
        safe_ordered = jnp.clip(ordered, 0, n - 1)
        target_gone = (units.orders[:, 0] == Order.ATTACK_UNIT) & ~alive[safe_ordered]
        if air:  # An order to attack what the weapon cannot hit ends too.
            target_gone = target_gone | ((units.orders[:, 0] == Order.ATTACK_UNIT)
                                         & ~hits_layer(data, units.type[safe_ordered]))
        units = pop_order(units, target_gone & alive)
    order = units.orders[:, 0]

    if combat:
        target = _rows(blocks, lambda block: _select_targets(units, data, block), NO_TARGET)
    else:
        target = jnp.full(n, NO_TARGET, jnp.int32)
    has_target = (target >= 0) & alive
    safe_target = jnp.clip(target, 0, n - 1)
    # Targets are enemies, so each lies in its row's block's columns.
    target_gap = (_rows(blocks, lambda b: b.at(target[b.rows]), jnp.inf) if combat
                  else jnp.zeros(n))
    in_range = has_target & (target_gap <= data.range) & (data.damage > 0)

    # Where each unit heads.
    order_goal = units.order_pos[:, 0]
    chasing = has_target & ~in_range & (order != Order.HOLD)
    goal = jnp.where(chasing[:, None], pos[safe_target], order_goal)
    walking = ((order == Order.MOVE) | (order == Order.ATTACK_MOVE) | (order == Order.PATROL)
               | (order == Order.BUILD) | (order == Order.LAND))
    moving = alive & (chasing | (walking & ~has_target)) & (data.speed > 0)
    to_goal = goal - pos
    goal_dist = jnp.sqrt(squared_length(to_goal) + 1e-12)
    room = jnp.where(chasing, jnp.maximum(target_gap - data.range, 0.0) + 1e-3, goal_dist)
    # Working workers walk to their resource, Command Center or structure until they
    # touch it.
    gathering = jnp.zeros(n, bool)
    if workers:
        # No unit's type, owner or completion changes before the harvest below, so this
        # holds for it too (by the positions at the loop's start).
        depot = harvest.nearest_depot(units)
        units = harvest.resolve_returns(units, depot)
        gathering = harvest.working(units)
        to_unit, unit_goal, unit_room = harvest.approach(units, data.radius, static_slots or 0)
        goal = jnp.where(to_unit[:, None], pos[unit_goal], goal)
        to_goal = goal - pos
        goal_dist = jnp.sqrt(squared_length(to_goal) + 1e-12)
        room = jnp.where(to_unit, unit_room, room)
        moving = moving | (alive & to_unit & (data.speed > 0))
    step = jnp.where(moving, jnp.minimum(data.speed, room), 0.0)
    direction = to_goal / goal_dist[:, None]
    new_pos = pos + direction * step[:, None]

    # Working workers, and SCVs on their way to a building site, pass through other units
    # (without path finding, a worker would stick behind structures on its way).
    passes = gathering | (order == Order.BUILD)
    first = lambda tree: leading_slots(tree, colliders)  # noqa: E731
    pushed = _resolve_collisions(first(new_pos), first(alive & ~passes), first(data), sized,
                                 colliders or jitter_slots or n, static_slots or 0)
    new_pos = jnp.concatenate([pushed, new_pos[len(pushed):]])
    x0, y0, x1, y1 = playable
    new_pos = jnp.clip(new_pos, jnp.array([x0, y0]), jnp.array([x1, y1]))
    new_pos = jnp.where(alive[:, None], new_pos, pos)

    # Facing follows movement, or turns to the target when attacking.
    moved = new_pos - pos
    to_target = pos[safe_target] - pos
    face_vec = jnp.where(in_range[:, None], to_target, moved)
    heading = jnp.where((squared_length(face_vec) > 1e-10)[:, None], face_vec, 0.0)
    facing = facing_of(heading, units.facing) if face else units.facing

    # Attacks: instant hits, summed by target. `cooldown` is the loops left
    # before the weapon is ready at the start of this loop; a weapon fires once that is
    # <= 0, keeps the fraction of a loop it was late by (in (-1, 0]), and then waits
    # its cooldown plus a jitter of -1..+2 loops. A ready weapon that does not fire
    # gains no credit.
    fires = in_range & (units.cooldown <= 0.0) & alive
    if not combat:
        fires = jnp.zeros(n, bool)
    single = fires & (data.burst <= 0) if bursts else fires
    hits = jnp.where(single, _damage_per_hit(data, safe_target), 0.0)
    if combat:
        # Most loops no unit fires: no damage, and no unit is called to answer.
        shapes = [b._replace(dist=None, gap=jax.ShapeDtypeStruct(b.gap.shape, b.gap.dtype),
                             enemy=None) for b in blocks]
        damage, attacker, called = _skip_unless(
            jnp.any(fires), functools.partial(_strikes, shapes),
            (units, data, fires, hits, safe_target),
            (jnp.zeros(n, jnp.float32), jnp.full(n, -1, jnp.int32),
             jnp.full(n, -1, jnp.int32)), n)
    else:
        damage = jnp.zeros(n, jnp.float32)
    # Volatile bursts: a unit that attacks with one dies, and one killed by this loop's
    # other damage bursts too (a single round: no map has bursting units on both sides).
    exploded = jnp.zeros(n, bool)
    if bursts:
        exploded = fires & (data.burst > 0)
        splashes = [_splash(data, block) for block in blocks]

        def received(by):  # float32[N]: the splash each unit takes from the units `by`.
            total = jnp.zeros(n, jnp.float32)
            for block, splash in zip(blocks, splashes):
                total = total.at[block.cols].add(
                    jnp.sum(jnp.where(by[block.rows, None], splash, 0.0), axis=0))
            return total

        killed = alive & (units.health - damage - received(exploded) <= 0) & ~exploded
        exploding = exploded | (killed & (data.burst > 0))
        dealt = jnp.concatenate(_static_fill([splash.sum(axis=1) for splash in splashes],
                                             blocks[0].rows.start, 0.0))
        hits = hits + jnp.where(exploding, dealt, 0.0)
        damage = damage + received(exploding)
    jitter = _cooldown_jitter(key, jitter_slots or n)[:n]
    ready = units.cooldown <= 0.0
    cooldown = jnp.where(fires, units.cooldown + data.cooldown + jitter - 1.0,
                         jnp.where(ready, 0.0, units.cooldown - 1.0))

    # A unit hit while idle turns on (one of) its attackers, and so does an idle unit
    # whose ally within its acquisition range was hit.
    new_target = target
    if combat:
        answer = jnp.where(attacker >= 0, attacker, called)
        idle = units.orders[:, 0] == Order.NONE
        retaliate = idle & (answer >= 0) & (units.target < 0) & (data.damage > 0)
        if air:
            retaliate = retaliate & hits_layer(data, units.type[jnp.clip(answer, 0, n - 1)])
        new_target = jnp.where(retaliate, answer, target)

    health = units.health - damage
    died = alive & (((data.max_health > 0) & (health <= 0)) | exploded)
    alive = alive & ~died

    minerals = vespene = jnp.zeros(n, jnp.float32)
    if workers:
        gap_after = (jnp.sqrt(squared_length(new_pos - new_pos[unit_goal]))
                     - data.radius - data.radius[unit_goal])
        units = units.replace(pos=new_pos, alive=alive)
        units, minerals, vespene, ended = harvest.harvest(
            units, gathering & (gap_after <= harvest.REACH), depot, field_slots,
            static_slots or 0)
        units = pop_order(units, ended)
        alive = units.alive
    by_player = lambda x: jnp.stack([jnp.sum(jnp.where(units.owner == p, x, 0.0))  # noqa: E731
                                     for p in BY_PLAYER])
    events = LoopEvents(
        died=died, damage_dealt=by_player(hits), damage_taken=by_player(damage),
        minerals=by_player(minerals), vespene=by_player(vespene),
        created=jnp.zeros(n, bool), heading=heading)

    if researched is not None:
        stim, slow = research.timers(units, researched, single, safe_target)
        units = units.replace(stim=jnp.where(alive, stim, 0.0), slow=jnp.where(alive, slow, 0.0))
    units = units.replace(
        pos=new_pos, facing=facing, cooldown=jnp.where(alive, cooldown, 0.0),
        health=jnp.where(alive, health, 0.0), alive=alive,
        target=jnp.where(alive, new_target, NO_TARGET),
        selected=units.selected & alive, groups=jnp.where(alive, units.groups, 0))
    return _complete_orders(units, pos, step, goal_dist, has_target, moving), events


def _splash(data, block: PairBlock):
    """float32[R, C]: the damage a burst of each row unit deals to each column unit (0
    where the column is not an enemy within the row's `burst` radius of its centre)."""
    reach = block.enemy & (block.dist - data.radius[None, block.cols]
                           <= data.burst[block.rows, None])
    columns = jnp.broadcast_to(jnp.arange(block.cols.start, block.cols.stop),
                               block.dist.shape)
    return jnp.where(reach, _damage_per_hit(slot_rows(data, block.rows), columns, data), 0.0)


def _strikes(blocks: list[PairBlock], args):
    """The loop's hits summed per target, and who answers them.

    Sums over each block's pairs, not scatters, so that the loop can be compiled whole
    (`devices.compile_small_loops_whole`); exact in any order, as damage comes in halves
    of hit points (at least 0.5 a hit). A row's column is only used where it fires or
    hits, and then its target is in that block's columns.

    Args:
      blocks: the loop's pair blocks; only their slot ranges and shapes are read.
      args: (units, data, fires, hits, target): the units at the loop's start and their
        stats; bool[N] which fire, float32[N] the damage each deals and int32[N] their
        targets (clipped into the slots).

    Returns:
      float32[N] the damage each unit takes; int32[N] the highest slot that fires at
      each, or -1; int32[N] the attacker of a hit ally each is called to answer
      (`_called`), or -1.
    """
    units, data, fires, hits, target = args
    rows = jnp.arange(units.num_slots)
    hit_by = [_hit_by(block, target) for block in blocks]
    damage = _cols(blocks, [_fold_rows(jnp.add, jnp.where(hit, hits[b.rows, None], 0.0))
                            for b, hit in zip(blocks, hit_by)], 0.0)
    attacker = _cols(blocks, [
        _fold_rows(jnp.maximum, jnp.where(hit & fires[b.rows, None], rows[b.rows, None], -1))
        for b, hit in zip(blocks, hit_by)], -1)
    called = _rows(blocks, lambda block: _called(units, data, block, fires, target, attacker),
                   -1)
    return damage, attacker, called


def _called(units: Units, data, block: PairBlock, fires, target, attacker):
    """int32[R]: for each row unit, the attacker of an ally within its acquisition range
    that was hit this loop (the highest such attacker's slot), or -1.

    The allies hit are the targets of the column units that fire: a unit's target is
    an enemy, so a row unit's hit allies are targets of units in its block's columns.

    Args:
      fires: bool[N] units that fire this loop; target: int32[N] their targets.
      attacker: int32[N] the highest slot that fires at each unit, or -1.
    """
    rows = jnp.arange(units.num_slots)[block.rows]
    hit = target[block.cols]  # [C]
    gap = (distances(units.pos[block.rows], units.pos[hit]) - data.radius[block.rows, None]
           - data.radius[hit][None, :])
    ally = ((units.owner[block.rows, None] == units.owner[hit][None, :])
            & units.alive[block.rows, None] & units.alive[hit][None, :]
            & (rows[:, None] != hit[None, :]))
    calls = fires[None, block.cols] & ally & (gap <= data.acquire[block.rows, None])
    return jnp.max(jnp.where(calls, attacker[hit][None, :], -1), axis=1)


def _damage_per_hit(data, target, target_data=None):
    """The damage one attack of unit i deals to the slots `target[i]`: each of its hits
    deals the damage, plus its bonus against targets with the bonus attribute, minus
    armour, and at least 0.5 (the game's minimum).

    Args:
      data: per-unit stats of the R attackers.
      target: int32[R] (one target each) or int32[R, M] target slots.
      target_data: the stats of the slots `target` indexes (default `data`).

    Returns:
      float32 of `target`'s shape.
    """
    target_data = data if target_data is None else target_data
    own = lambda x: x.reshape(x.shape + (1,) * (target.ndim - 1))  # noqa: E731
    bonus = (target_data.attributes[target] & own(data.bonus_attribute)) > 0
    hit = jnp.maximum(own(data.damage) + jnp.where(bonus, own(data.bonus), 0.0)
                      - target_data.armor[target], 0.5)
    return own(data.attacks).astype(jnp.float32) * hit


def _complete_orders(units: Units, old_pos, step, goal_dist, has_target, moving) -> Units:
    """Ends move orders that arrived (or are blocked next to their goal); turns patrols."""
    speed = _data(units.type).speed
    travelled = jnp.sqrt(squared_length(units.pos - old_pos))
    remaining = goal_dist - step
    blocked = moving & (travelled < STUCK_FRACTION * speed) & (goal_dist < BLOCKED_ARRIVAL)
    arrived = units.alive & ~has_target & ((moving & (remaining <= ARRIVAL)) | blocked)
    return _unless_none(arrived, _end_arrived, units)


def _end_arrived(units: Units, arrived) -> Units:
    """Ends the move orders of units `arrived` (bool[N]) at their goal; turns patrols."""
    order = units.orders[:, 0]
    walking_done = arrived & ((order == Order.MOVE) | (order == Order.ATTACK_MOVE))
    patrol_turn = mask_once(arrived & (order == Order.PATROL))
    units = units.replace(
        order_pos=jnp.concatenate([
            jnp.where(patrol_turn[:, None], units.patrol_origin, units.order_pos[:, 0])[:, None],
            units.order_pos[:, 1:]], axis=1),
        patrol_origin=jnp.where(patrol_turn[:, None], units.order_pos[:, 0],
                                units.patrol_origin))
    return _shift_orders(units, walking_done)


def colliding(data):
    """bool[N]: which of N units (their `UNIT_DATA` rows) collide: ground units with
    health and structures; items (beacons, shards) have a radius for rendering only,
    flying units pass over everything, and ground units walk over a lowered depot."""
    solid = (data.max_health > 0) | ((data.attributes & Attribute.STRUCTURE) > 0)
    return solid & ~data.flying & ~data.walkable


# Collision pushes are summed in fixed point, in units of 2**-bits world units (20 bits:
# below a float32 position's resolution on a 64-unit map; fewer on maps with so many
# slots that N pushes could overflow int32, `push_bits`): integer sums do not depend on
# the order of the additions, which XLA chooses by the array's length, so a game run on
# its leading slots (`Simulator`) moves its units exactly as on all of them.
PUSH_BITS = 20


def push_bits(slots: int) -> int:
    """The fixed-point bits of the collision pushes of a map with `slots` colliding
    slots: `PUSH_BITS`, or fewer where `slots` pushes of both largest radii could
    overflow int32 (18 bits of a world unit for 768 slots: finer than a float32
    position's resolution on a 256-unit map)."""
    most = pair_width(slots) * 2 * float(UNIT_DATA.radius.max())
    bits = PUSH_BITS
    while most * 2 ** bits >= 2 ** 31:
        bits -= 1
    return bits


def pair_width(n: int) -> int:
    """The row length the collision push's [N, N] pairs are computed at: N up to 32
    rounded up to a multiple of 8, larger N as it is.

    XLA's CPU backend is far slower on short rows whose length is not a multiple of 8
    (it vectorises the innermost loop): the push of 28 units took 1.7x as long as of
    32, of 20 2.2x as long as of 24 (per environment, at 1 to 1,024 environments;
    docs/benchmarks.md). Past 32 the rounding measured no better (68 -> 72 slower,
    74 -> 80 faster), so it is not done.
    """
    return -(-n // 8) * 8 if 8 < n <= 32 else n


def _resolve_collisions(pos, alive, data, sized: bool = False, slots: int | None = None,
                        static_slots: int = 0):
    """Pushes overlapping ground units apart; immobile ones (structures, resources) don't
    move. Items that do not collide (`colliding`) are ignored.

    The pairs are computed at `pair_width(N)`, the padding as units that do not collide
    (they push nothing, and the sums are exact). The x and y components are separate
    [N, N] arrays, summed over each row by one variadic reduce: a reduction over an
    [N, N, 2] array is several times slower on XLA's CPU backend, and two sums
    recompute each pair's distance (1.04x at one environment, docs/benchmarks.md). Each
    push is at most both radii, so N of them sum within int32 for every map (checked).

    `sized` (static): the distances as `hypot`. XLA compiles `sqrt(dx * dx + dy * dy)`
    differently for N <= 32 (one loop fusion) than above, and its last bit can differ;
    `hypot`'s does not, but it cuts FindAndDefeatZerglings' agent steps/s by a quarter,
    so only the maps run on several slot counts use it (docs/benchmarks.md).

    `slots` (static): the map's colliding slots (N where None), whose `push_bits` the
    sums take, so that a run on leading slots sums as one on all of them.

    `static_slots` (static) S: the first S slots hold only resources, which block but
    never move: the pairs are [N - S, N], the pushes of the slots from S on.
    """
    n = len(pos)
    width = pair_width(n)
    bits = push_bits(max(n, slots or n))
    pad = lambda x: jnp.pad(x, [(0, width - n)] + [(0, 0)] * (x.ndim - 1))  # noqa: E731
    collides = pad(alive & colliding(data))
    mobile = pad(data.speed > 0)
    radius = pad(data.radius)
    xy = pad(pos)
    rows = slice(static_slots, width)  # The slots that can be pushed (and the padding).
    dx = xy[rows, None, 0] - xy[None, :, 0]
    dy = xy[rows, None, 1] - xy[None, :, 1]
    dist = jnp.hypot(dx, dy) if sized else jnp.sqrt(dx * dx + dy * dy + 1e-12)
    overlap = radius[rows, None] + radius[None, :] - dist
    itself = jnp.arange(static_slots, width)[:, None] == jnp.arange(width)[None, :]
    pair = collides[rows, None] & collides[None, :] & (overlap > 0) & ~itself
    # Share of the overlap i gives way: half between two mobile units, all against a wall.
    share = jnp.where(mobile[None, :], 0.5, 1.0) * mobile[rows, None]
    push = jnp.where(pair, overlap * share, 0.0)
    # Coincident units separate along a fixed per-pair direction. The directions are
    # constants of the compiled program: computed in it, XLA hoists them out of the game
    # loop but still evaluates N cosines and sines (library calls) per agent step.
    with jax.ensure_compile_time_eval():
        angle = jnp.arange(width) * 2.4
        tie_x, tie_y = jnp.cos(angle), jnp.sin(angle)
    apart = dist > 1e-4
    # One division per pair, not one per axis: 1.05x at 64 environments, 1.03x at one.
    inverse = 1.0 / dist
    along = lambda d, tie: jnp.where(apart, d * inverse, tie[rows, None] - tie[None, :])  # noqa: E731

    fixed = lambda d, tie: (along(d, tie) * push * 2 ** bits).astype(jnp.int32)  # noqa: E731
    totals = jax.lax.reduce((fixed(dx, tie_x), fixed(dy, tie_y)), (np.int32(0), np.int32(0)),
                            lambda a, b: (a[0] + b[0], a[1] + b[1]), (1,))
    pushed = jnp.stack([total[:n - static_slots] for total in totals], axis=-1)
    return jnp.concatenate([pos[:static_slots],
                            pos[static_slots:] + pushed.astype(jnp.float32) * 2 ** -bits])
