"""Scripted agents for CollectMineralsAndGas and BuildMarines: a competent human's macro.

One stateless policy plays both maps from `feature_units`, the `player` vector, the
selection and `last_actions`. Each agent step it does the first job that applies, one
action at a time (a job that needs a selection first selects, and acts on the next
step):

1. an idle SCV selected by the previous step goes to work: to a Refinery short of its
   3 workers, else to the mineral field nearest the Command Center (workers spread over
   the line by themselves), or once that line has 3 workers per field, to the nearest
   field beyond the base; otherwise any idle SCV is selected;
2. a Supply Depot when the free supply runs low (3, plus 2 per Barracks) and none is
   being built, at the first free site of a fixed layout;
3. SCVs from the Command Center, keeping one in training, up to the plan's count;
4. Refineries (on the free geyser nearest the Command Center) once the plan's SCV
   counts are reached, and 3 workers sent to each;
5. Marines from all Barracks, keeping one in training at each;
6. Barracks up to the plan's count, once a Supply Depot stands.

The camera stays where the map puts it (both maps lock it), so the layout's sites are
fixed screen points.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.agents.calls import call, pick
from sc2jax.environment.engine.minigames.economy import CAMERA
from sc2jax.environment.engine.observation import BASE_RADIUS
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.features import PlayerRelative
from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.environment.interface.observation_tables import FeatureUnit, Player

_SCV, _CC, _DEPOT, _REFINERY, _BARRACKS = 45, 18, 19, 20, 21
_MINERAL_FIELD, _GEYSER = 341, 342
F = FUNCTIONS

# Sites (world x, y), in the order they are used. Supply Depots in rows along the top and
# bottom of the playable area, the first 16 clear of CollectMineralsAndGas' geysers;
# Barracks in a block right of the Command Center, between the depot rows.
DEPOT_SITES = np.array([(x, y) for xs in ((30.0, 32.0, 34.0, 36.0), (38.0, 40.0, 42.0, 44.0))
                        for y in (35.0, 20.0, 33.0, 22.0) for x in xs], np.float32)
BARRACKS_SITES = np.array([(x, y) for x in (34.5, 37.5, 40.5, 43.5) for y in (27.5, 24.5, 30.5)],
                          np.float32)


class Plan(NamedTuple):
    """What the agent builds on a map.

    Attributes:
      workers: SCVs to keep training up to.
      refineries_at: SCV counts at which the 1st, 2nd, ... Refinery is started.
      barracks: Barracks to build.
    """

    workers: int
    refineries_at: tuple[int, ...]
    barracks: int


PLANS = {"CollectMineralsAndGas": Plan(workers=44, refineries_at=(16, 18, 24, 26), barracks=0),
         "BuildMarines": Plan(workers=22, refineries_at=(), barracks=8)}


def _to_pixel(world, res):
    """int32[..., 2] screen pixels of world points (the map's camera, 24 units wide)."""
    scale = res / 24.0
    x = (world[..., 0] - CAMERA[0]) * scale + res / 2
    y = res / 2 - (world[..., 1] - CAMERA[1]) * scale
    return jnp.stack([x, y], -1).astype(jnp.int32)


def economy(key, obs, plan: Plan) -> DenseAction:
    """One step of the macro policy (module docstring) for `plan`."""
    del key
    res = obs["feature_screen"].shape[-1]
    rows = obs["feature_units"]
    kind = rows[:, FeatureUnit.unit_type]
    own = (kind != 0) & (rows[:, FeatureUnit.alliance] == PlayerRelative.SELF)
    xy = rows[:, jnp.array([FeatureUnit.x, FeatureUnit.y])]
    done = rows[:, FeatureUnit.build_progress] >= 100
    queue = rows[:, FeatureUnit.order_length]
    player = obs["player"]
    minerals = player[Player.minerals]
    free_food = player[Player.food_cap] - player[Player.food_used]
    single = obs["single_select"][0, 0]
    selected = jnp.where(single != 0, single, obs["multi_select"][0, 0])
    last = obs["last_actions"][0]

    def mine(k):
        return own & (kind == k)

    scv, cc, depot, refinery, barracks = (mine(k) for k in (_SCV, _CC, _DEPOT, _REFINERY,
                                                             _BARRACKS))
    cc_xy = xy[jnp.argmax(cc)].astype(jnp.float32)
    workers = player[Player.food_workers]

    def nearest(mask, point):
        d2 = jnp.sum((xy.astype(jnp.float32) - point) ** 2, -1)
        return jnp.argmin(jnp.where(mask, d2, jnp.inf))

    # Builders and gas workers come from the mineral line: the SCV nearest the field
    # nearest the Command Center.
    field = nearest(kind == _MINERAL_FIELD, cc_xy)
    choose_scv = call(F.select_point.id, screen=xy[nearest(scv, xy[field].astype(jnp.float32))])

    def with_scv(act):
        """`act` if an SCV is selected alone, else select one from the mineral line."""
        return pick((single == _SCV) & scv.any(), act, choose_scv)

    # 1. Idle workers.
    short = refinery & done & (rows[:, FeatureUnit.assigned_harvesters]
                               < rows[:, FeatureUnit.ideal_harvesters])
    # With 3 workers per field of its base, the Command Center's line is saturated: new
    # workers go to the nearest field outside the base (a long walk, but income).
    cc_row = rows[jnp.argmax(cc)]
    ideal = cc_row[FeatureUnit.ideal_harvesters]
    saturated = (ideal > 0) & (2 * cc_row[FeatureUnit.assigned_harvesters] >= 3 * ideal)
    d2_cc = jnp.sum((xy.astype(jnp.float32) - cc_xy) ** 2, -1)
    far = (kind == _MINERAL_FIELD) & (d2_cc > (BASE_RADIUS * res / 24.0) ** 2)
    mine_at = jnp.where(saturated & far.any(), nearest(far, cc_xy), field)
    send = pick(short.any(), call(F.Smart_screen.id, screen=xy[jnp.argmax(short)]),
                call(F.Harvest_Gather_screen.id, screen=xy[mine_at]))
    sent_idle = (last == F.select_idle_worker.id) & (selected == _SCV)
    idle = player[Player.idle_worker_count] > 0

    # 2. Supply.
    n_barracks = jnp.sum(barracks)
    need_depot = ((free_food <= 3 + 2 * n_barracks) & (player[Player.food_cap] < 200)
                  & ~(depot & ~done).any() & (minerals >= 100))
    structure = own & ((kind == _CC) | (kind == _DEPOT) | (kind == _BARRACKS))

    def free_site(sites):
        """(pixel int32[2], any free): the first site without a structure on it."""
        pixels = _to_pixel(jnp.asarray(sites), res)
        d2 = jnp.sum((pixels[:, None, :] - xy[None, :, :]) ** 2, -1)
        taken = jnp.any(structure[None, :] & (d2 <= (res / 24.0) ** 2), axis=1)
        return pixels[jnp.argmin(taken)], ~taken.all()

    depot_site, depot_room = free_site(DEPOT_SITES)
    build_depot = with_scv(call(F.Build_SupplyDepot_screen.id, screen=depot_site))
    need_depot = need_depot & depot_room

    # 3. SCVs.
    need_scv = ((workers < plan.workers) & (queue[jnp.argmax(cc)] < 1) & cc.any()
                & (free_food >= 1) & (minerals >= 50))
    train_scv = pick(selected == _CC, call(F.Train_SCV_quick.id),
                     call(F.select_point.id, screen=xy[jnp.argmax(cc)]))

    # 4. Gas.
    thresholds = jnp.asarray(plan.refineries_at + (10_000,), jnp.int32)
    n_refineries = jnp.sum(refinery)
    geyser = nearest(kind == _GEYSER, cc_xy)
    need_refinery = ((workers >= thresholds[jnp.minimum(n_refineries, len(thresholds) - 1)])
                     & (kind == _GEYSER).any() & (minerals >= 75))
    build_refinery = with_scv(call(F.Build_Refinery_screen.id, screen=xy[geyser]))
    staff_gas = with_scv(call(F.Smart_screen.id, screen=xy[jnp.argmax(short)]))

    # 5-6. Barracks and Marines.
    barracks_site, barracks_room = free_site(BARRACKS_SITES)
    need_barracks = ((n_barracks < plan.barracks) & (depot & done).any() & (minerals >= 150)
                     & barracks_room)
    build_barracks = with_scv(call(F.Build_Barracks_screen.id, screen=barracks_site))
    ready = barracks & done
    need_marine = ((ready & (queue < 1)).any() & (free_food >= 1) & (minerals >= 50))
    train_marine = pick(selected == _BARRACKS, call(F.Train_Marine_quick.id),
                        call(F.select_point.id, select_point_act=2,  # select_all_type
                             screen=xy[jnp.argmax(ready)]))

    jobs = [(sent_idle, send), (idle, call(F.select_idle_worker.id)),
            (need_depot, build_depot), (need_scv, train_scv),
            (need_refinery, build_refinery), (short.any(), staff_gas),
            (need_marine, train_marine), (need_barracks, build_barracks)]
    action = call(F.no_op.id)
    for condition, act in reversed(jobs):
        action = pick(condition, act, action)
    return action
