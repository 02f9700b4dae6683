"""Scripted agents: how a competent human plays each mini-game, as pure jittable policies.

They read the padded observation of one environment (as `Simulator` returns it) and
return one `DenseAction`; vmap them for a batch. They are reference points for learning
and a check on the mechanics: a scripted agent a human could beat by a wide margin
points to a missing mechanic (docs/fidelity.md).

    policy = scripted_policy("MoveToBeacon", sim.fmt)
    action = policy(key, timestep.observation)

What each needs from the observation format is checked when the policy is built
(`required_format`).
"""

from __future__ import annotations

import functools

import jax.numpy as jnp

from sc2jax.environment.agents.calls import Policy, call, pick
from sc2jax.environment.agents.scripted_economy import PLANS, economy
from sc2jax.environment.engine.minigames import get_map
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.features import PlayerRelative, Visibility
from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.environment.interface.observation_tables import FeatureUnit
from sc2jax.environment.interface.specs import ObservationFormat

_NO_OP = FUNCTIONS.no_op.id
_SELECT_POINT = FUNCTIONS.select_point.id
_SELECT_ARMY = FUNCTIONS.select_army.id
_MOVE_SCREEN = FUNCTIONS.Move_screen.id
_ATTACK_MINIMAP = FUNCTIONS.Attack_minimap.id
_ATTACK_SCREEN = FUNCTIONS.Attack_screen.id
_BANELING = 9  # The StarCraft II unit id.
# DefeatZerglingsAndBanelings: marines stutter-step while a baneling is this close (world
# units, from the marines' centre), and each step back aims this far (world units).
_BANELING_DANGER = 4.5
_RETREAT = 4.0


def _units(obs, alliance):
    """(mask bool[U], xy int32[U, 2], selected bool[U]) of the on-screen units of an
    alliance, from `feature_units`."""
    rows = obs["feature_units"]
    mask = (rows[:, FeatureUnit.unit_type] != 0) & (rows[:, FeatureUnit.alliance] == alliance)
    xy = rows[:, jnp.array([FeatureUnit.x, FeatureUnit.y])]
    return mask, xy, mask & (rows[:, FeatureUnit.is_selected] > 0)


def _nearest(origin, points, mask):
    """(index, distance²) of the nearest masked point to `origin` (float32[2])."""
    d2 = jnp.sum((points.astype(jnp.float32) - origin) ** 2, axis=-1)
    d2 = jnp.where(mask, d2, jnp.inf)
    index = jnp.argmin(d2)
    return index, d2[index]


def move_to_beacon(key, obs) -> DenseAction:
    """Selects the marine, then moves it onto the beacon (PySC2's scripted agent)."""
    del key
    marine, _, selected = _units(obs, PlayerRelative.SELF)
    beacon, beacon_xy, _ = _units(obs, PlayerRelative.NEUTRAL)
    target = beacon_xy[jnp.argmax(beacon)]
    move = call(_MOVE_SCREEN, screen=target)
    act = pick(beacon.any(), move, call(_NO_OP))
    return pick(selected.any(), act, call(_SELECT_ARMY))


def collect_mineral_shards(key, obs) -> DenseAction:
    """Controls the two marines in turn: select one, send it to its nearest shard.

    Each marine takes the shards that are nearer to it than to the other marine, so the
    two split the field instead of racing for the same shard. Marines are handled in
    turn, two agent steps each (select, move), by the game loop.
    """
    del key
    marine, marine_xy, selected = _units(obs, PlayerRelative.SELF)
    shard, shard_xy, _ = _units(obs, PlayerRelative.NEUTRAL)
    order = jnp.cumsum(marine) - 1  # 0 for the first marine row, 1 for the second.
    count = jnp.sum(marine)
    turn = (obs["game_loop"][0] // 16) % jnp.maximum(count, 1)
    me = jnp.argmax(marine & (order == turn))
    other = jnp.argmax(marine & (order != turn))
    me_xy = marine_xy[me].astype(jnp.float32)
    shard_f = shard_xy.astype(jnp.float32)
    mine = jnp.sum((shard_f - me_xy) ** 2, -1) <= jnp.sum(
        (shard_f - marine_xy[other].astype(jnp.float32)) ** 2, -1)
    mine = shard & jnp.where(count > 1, mine, True)
    index, _ = _nearest(me_xy, shard_xy, jnp.where(mine.any(), mine, shard))
    only_me = selected[me] & (jnp.sum(selected) == 1)
    move = pick(shard.any(), call(_MOVE_SCREEN, screen=shard_xy[index]), call(_NO_OP))
    select = call(_SELECT_POINT, screen=marine_xy[me])
    return pick(marine.any(), pick(only_me, move, select), call(_NO_OP))


def find_and_defeat_zerglings(key, obs, minimap_layers: dict[str, int]) -> DenseAction:
    """Selects the army and attack-moves on the minimap: to the nearest visible enemy,
    else to the nearest unexplored pathable cell, else (the map explored, zerglings
    respawned out of sight) to the nearest pathable cell not in sight."""
    del key
    mm = obs["feature_minimap"]
    relative = mm[minimap_layers["player_relative"]]
    visibility = mm[minimap_layers["visibility_map"]]
    pathable = mm[minimap_layers["pathable"]] > 0
    h, w = relative.shape
    ys, xs = jnp.mgrid[0:h, 0:w]
    points = jnp.stack([xs, ys], -1).reshape(-1, 2)
    own = (relative == PlayerRelative.SELF).reshape(-1)
    centre = jnp.sum(points * own[:, None], 0) / jnp.maximum(jnp.sum(own), 1)
    enemy = (relative == PlayerRelative.ENEMY).reshape(-1)
    unexplored = ((visibility == Visibility.HIDDEN) & pathable).reshape(-1)
    unseen = ((visibility != Visibility.VISIBLE) & pathable).reshape(-1)
    goals = jnp.where(enemy.any(), enemy, jnp.where(unexplored.any(), unexplored, unseen))
    goal, _ = _nearest(centre, points, goals)
    attack = pick(goals.any(), call(_ATTACK_MINIMAP, minimap=points[goal]), call(_NO_OP))
    army_selected = obs["single_select"][0, 0] + obs["multi_select"][0, 0] > 0
    return pick(army_selected, attack, call(_SELECT_ARMY))


def _world_scale(obs) -> float:
    """World units per screen pixel (the screen is 24 world units wide)."""
    return 24.0 / obs["feature_screen"].shape[-1]


def _army_ready(obs):
    """(marine mask, marine xy, marine centre float32[2], every marine selected)."""
    marine, marine_xy, selected = _units(obs, PlayerRelative.SELF)
    centre = jnp.sum(marine_xy * marine[:, None], 0) / jnp.maximum(jnp.sum(marine), 1)
    return marine, marine_xy, centre, jnp.sum(selected) == jnp.sum(marine)


def defeat_roaches(key, obs) -> DenseAction:
    """Focus fire: every marine attacks the weakest roach (the nearest of equals), and
    the order is renewed each step, as the map's own demo script does; the army is
    selected first whenever some marine is not."""
    del key
    _, _, centre, ready = _army_ready(obs)
    enemy, enemy_xy, _ = _units(obs, PlayerRelative.ENEMY)
    health = obs["feature_units"][:, FeatureUnit.health].astype(jnp.float32)
    d2 = jnp.sum((enemy_xy.astype(jnp.float32) - centre) ** 2, -1)
    target = jnp.argmin(jnp.where(enemy, health * 1e4 + d2, jnp.inf))
    attack = pick(enemy.any(), call(_ATTACK_SCREEN, screen=enemy_xy[target]), call(_NO_OP))
    return pick(ready, attack, call(_SELECT_ARMY))


def defeat_zerglings_and_banelings(key, obs) -> DenseAction:
    """Kites the banelings: the army shoots the nearest baneling (from range, so that it
    bursts away from the marines), then the nearest zergling; while a baneling is within
    `_BANELING_DANGER` of the marines' centre it stutter-steps, shooting on one agent step
    and stepping straight away from that baneling on the next."""
    del key
    marine, _, centre, ready = _army_ready(obs)
    enemy, enemy_xy, _ = _units(obs, PlayerRelative.ENEMY)
    kind = obs["feature_units"][:, FeatureUnit.unit_type]
    baneling = enemy & (kind == _BANELING)
    scale = _world_scale(obs)
    goals = jnp.where(baneling.any(), baneling, enemy)
    target, _ = _nearest(centre, enemy_xy, goals)
    nearest_bane, d2 = _nearest(centre, enemy_xy, baneling)
    away = centre - enemy_xy[nearest_bane].astype(jnp.float32)
    away = away / jnp.maximum(jnp.sqrt(jnp.sum(away * away)), 1e-3)
    res = obs["feature_screen"].shape[-1]
    retreat_xy = jnp.clip(jnp.round(centre + away * _RETREAT / scale), 0, res - 1)
    # Stutter-step: while a baneling is close, shoot on every other step, step back on
    # the others.
    back_step = (obs["game_loop"][0] // 8) % 2 == 1
    danger = baneling.any() & (d2 * scale * scale < _BANELING_DANGER ** 2) & back_step
    attack = pick(enemy.any(), call(_ATTACK_SCREEN, screen=enemy_xy[target]), call(_NO_OP))
    act = pick(danger, call(_MOVE_SCREEN, screen=retreat_xy.astype(jnp.int32)), attack)
    return pick(ready | ~marine.any(), act, call(_SELECT_ARMY))


def required_format(map_name: str) -> dict:
    """The `ObservationFormat` settings a map's scripted agent needs (for `make`)."""
    if map_name in ("CollectMineralsAndGas", "BuildMarines"):
        # Every unit of these maps is on the screen, up to their slots.
        return {"use_feature_units": True, "max_units": get_map(map_name).num_slots}
    if map_name in ("MoveToBeacon", "CollectMineralShards", "DefeatRoaches",
                    "DefeatZerglingsAndBanelings"):
        return {"use_feature_units": True}
    return {}


def scripted_policy(map_name: str, fmt: ObservationFormat) -> Policy:
    """The scripted agent of a map, for observations of format `fmt`.

    Raises:
      ValueError: for a map without a scripted agent, or a format lacking what the
        agent reads (feature units, or the minimap layers it uses).
    """
    needs = required_format(map_name)
    if needs.get("use_feature_units") and not fmt.use_feature_units:
        raise ValueError(f"the {map_name} scripted agent reads feature_units; build the "
                         f"environment with use_feature_units=True")
    if fmt.max_units < needs.get("max_units", 0):
        raise ValueError(f"the {map_name} scripted agent reads every unit; build the "
                         f"environment with max_units >= {needs['max_units']}, "
                         f"got {fmt.max_units}")
    if map_name == "MoveToBeacon":
        return move_to_beacon
    if map_name == "CollectMineralShards":
        return collect_mineral_shards
    if map_name == "FindAndDefeatZerglings":
        names = [f.name for f in fmt.minimap_layers]
        needed = ("player_relative", "visibility_map", "pathable")
        missing = [n for n in needed if n not in names]
        if missing:
            raise ValueError(f"the {map_name} scripted agent needs minimap layers {missing}; "
                             f"the format has {names}")
        index = {n: names.index(n) for n in needed}
        return lambda key, obs: find_and_defeat_zerglings(key, obs, index)
    if map_name == "DefeatRoaches":
        return defeat_roaches
    if map_name == "DefeatZerglingsAndBanelings":
        return defeat_zerglings_and_banelings
    if map_name in ("CollectMineralsAndGas", "BuildMarines"):
        return functools.partial(economy, plan=PLANS[map_name])
    raise ValueError(f"no scripted agent for map {map_name!r}; there are agents for "
                     f"{list(SCRIPTED_MAPS)}")


SCRIPTED_MAPS = ("MoveToBeacon", "CollectMineralShards", "FindAndDefeatZerglings",
                 "DefeatRoaches", "DefeatZerglingsAndBanelings", "CollectMineralsAndGas",
                 "BuildMarines")
