"""Applies one dense action to the state: UI functions and commands to the selection.

Each function id maps to an internal action kind (`KIND_TABLE`); `apply_action` runs the
kind's branch with `lax.switch`. Function availability is checked first against the
selection the agent saw; an unavailable function does nothing and reports
`ActionResult.NotSupported`, as the game does for an ability missing from the command
card. (The dm_env shell can instead raise before stepping, as PySC2's
`ensure_available_actions` does.)
"""

from __future__ import annotations

import enum
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine import terran_data, ui
from sc2jax.environment.engine.availability import (
    CARD_TABLE,
    MAKE_FUNCTIONS,
    available_actions,
)
from sc2jax.environment.engine.render import Renderer, pick_unit
from sc2jax.environment.engine.rules import (
    calldown,
    commands,
    liftoff,
    morphs,
    production,
    research,
)
from sc2jax.environment.engine.rules.geometry import clamp_camera
from sc2jax.environment.engine.rules.state import NO_TARGET, EnvState, Order, Owner
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType, game_name
from sc2jax.environment.engine.xla.fusion import set_static
from sc2jax.environment.interface.dense import DenseAction, zeros
from sc2jax.environment.interface.functions import FUNCTIONS, NUM_FUNCTIONS, FunctionType
from sc2jax.environment.interface.observation_tables import ScoreCumulative
from sc2jax.environment.interface.protocol_enums import ActionResult


class Kind(enum.IntEnum):
    """What the simulator does for a function."""

    UNSUPPORTED = 0
    NOOP = 1
    MOVE_CAMERA = 2
    SELECT_POINT = 3
    SELECT_RECT = 4
    CONTROL_GROUP = 5
    SELECT_UNIT = 6
    SELECT_ARMY = 7
    ATTACK = 8
    MOVE = 9
    PATROL = 10
    SMART = 11
    HOLD = 12
    STOP = 13
    GATHER = 14
    RETURN = 15
    BUILD = 16
    TRAIN = 17
    RALLY = 18
    CANCEL = 19
    CANCEL_LAST = 20
    SELECT_IDLE_WORKER = 21
    BUILD_QUEUE = 22
    BUILD_ADDON = 23
    MORPH = 24
    LIFT = 25
    LAND = 26
    STIM = 27
    CALLDOWN_MULE = 28


_BY_NAME = {
    "no_op": Kind.NOOP, "move_camera": Kind.MOVE_CAMERA, "select_point": Kind.SELECT_POINT,
    "select_rect": Kind.SELECT_RECT, "select_control_group": Kind.CONTROL_GROUP,
    "select_unit": Kind.SELECT_UNIT, "select_army": Kind.SELECT_ARMY,
    "Attack_screen": Kind.ATTACK, "Attack_minimap": Kind.ATTACK,
    "Move_screen": Kind.MOVE, "Move_minimap": Kind.MOVE,
    "Patrol_screen": Kind.PATROL, "Patrol_minimap": Kind.PATROL,
    "Smart_screen": Kind.SMART, "Smart_minimap": Kind.SMART,
    "HoldPosition_quick": Kind.HOLD, "Stop_quick": Kind.STOP,
    "Harvest_Gather_screen": Kind.GATHER, "Harvest_Return_quick": Kind.RETURN,
    "Rally_Workers_screen": Kind.RALLY, "Rally_Workers_minimap": Kind.RALLY,
    "Rally_Units_screen": Kind.RALLY, "Rally_Units_minimap": Kind.RALLY,
    "Cancel_quick": Kind.CANCEL, "Cancel_Last_quick": Kind.CANCEL_LAST,
    "select_idle_worker": Kind.SELECT_IDLE_WORKER, "build_queue": Kind.BUILD_QUEUE,
    "Build_TechLab_quick": Kind.BUILD_ADDON, "Build_Reactor_quick": Kind.BUILD_ADDON,
    **{name: Kind.MORPH for name in morphs.MODES},
    "Lift_quick": Kind.LIFT, "Land_screen": Kind.LAND, "Effect_Stim_quick": Kind.STIM,
    "Effect_CalldownMULE_screen": Kind.CALLDOWN_MULE,
    **{name: Kind.TRAIN for name in research.BUTTON.values()},
}
_BY_NAME.update({name: Kind.BUILD if name.startswith("Build_") else Kind.TRAIN
                 for name in MAKE_FUNCTIONS})
MAKES_TABLE = np.zeros(NUM_FUNCTIONS, np.int32)
"""The queue item (or structure) each function makes (0 where none)."""
MAKE_ABILITY = np.zeros(research.NUM_ITEMS, np.int32)
"""The ability id that builds or trains each unit type, or researches each research
(by queue item; 0 where none does)."""
for _name, _type in MAKE_FUNCTIONS.items():
    MAKES_TABLE[FUNCTIONS[_name].id] = _type
    MAKE_ABILITY[_type] = FUNCTIONS[_name].ability_id
for _research, _name in research.BUTTON.items():
    MAKES_TABLE[FUNCTIONS[_name].id] = research.item(_research)
    MAKE_ABILITY[research.item(_research)] = FUNCTIONS[research.FUNCTION[_research]].ability_id
for _type in np.flatnonzero(production.ADDON_KIND):  # Each add-on's own (specific) ability.
    MAKE_ABILITY[_type] = terran_data.unit(game_name(UnitType(_type)))["ability_id"]

ADDON_TABLE = np.zeros(NUM_FUNCTIONS, np.int32)
"""The `AddOn` each function builds (0 where none)."""
ADDON_TABLE[FUNCTIONS.Build_TechLab_quick.id] = production.AddOn.TECH_LAB
ADDON_TABLE[FUNCTIONS.Build_Reactor_quick.id] = production.AddOn.REACTOR

KIND_TABLE = np.zeros(NUM_FUNCTIONS, np.int32)
for _name, _kind in _BY_NAME.items():
    KIND_TABLE[FUNCTIONS[_name].id] = _kind
IS_MINIMAP = np.array([f.function_type == FunctionType.cmd_minimap for f in FUNCTIONS])


class _Context:
    """Values the branches share, computed once per action: a feature action's
    (`_Context(state, action, renderer)`: its screen or minimap point, and the unit drawn
    under a screen click), or a raw command's (`_Context.raw`: its world point and
    target unit)."""

    def __init__(self, state: EnvState, action: DenseAction, renderer: Renderer):
        units = state.units
        camera = renderer.camera
        self.shown = renderer.units_shown(state)
        self.pixel_pos = camera.world_to_pixel(state.camera, units.pos)
        self.pixel_radius = jnp.asarray(UNIT_DATA.radius)[units.type] * camera.pixels_per_unit
        sx, sy = camera.size
        px, py = self.pixel_pos[:, 0], self.pixel_pos[:, 1]
        self.on_screen = self.shown & (px >= 0) & (px < sx) & (py >= 0) & (py < sy)
        picked = pick_unit(units, self.on_screen, self.pixel_pos, self.pixel_radius,
                           action.screen)
        screen_point = camera.pixel_to_world(state.camera, action.screen)
        self.minimap_point = renderer.minimap.pixel_to_world(action.minimap)
        minimap = jnp.asarray(IS_MINIMAP)[action.function]
        self._aim(units, renderer, jnp.where(minimap, self.minimap_point, screen_point),
                  jnp.where(minimap, NO_TARGET, picked))  # Units are targeted on the screen.

    @classmethod
    def raw(cls, state: EnvState, point, target, renderer: Renderer) -> _Context:
        """A raw command's context: float32[2] world `point`, int32 `target` slot (or
        -1). The camera moves to the point; nothing is picked by the cursor."""
        self = cls.__new__(cls)
        self.shown = self.on_screen = jnp.zeros(state.units.num_slots, bool)
        self.pixel_pos = jnp.zeros_like(state.units.pos)
        self.pixel_radius = jnp.zeros(state.units.num_slots, jnp.float32)
        self.minimap_point = point
        self._aim(state.units, renderer, point, target)
        return self

    def _aim(self, units, renderer: Renderer, point, picked):
        """The target point, kept in the playable area (units stay inside it, so a point
        outside stands for the nearest point inside, where the unit stops and its order
        ends), and what the targeted unit `picked` (int32 slot or -1) is to the player:
        an enemy to attack, a mineral field or the player's Refinery to gather from,
        the player's unfinished structure to resume."""
        x0, y0, x1, y1 = renderer.geometry.playable
        self.point = jnp.clip(point, jnp.array([x0, y0], jnp.float32),
                              jnp.array([x1, y1], jnp.float32))
        self.picked = picked
        safe = jnp.maximum(picked, 0)
        clicked = picked >= 0
        picked_type = units.type[safe]
        own = units.owner[safe] == Owner.SELF
        self.enemy_under = clicked & (units.owner[safe] == Owner.ENEMY)
        self.resource_under = clicked & (units.contents[safe] > 0) & (
            (picked_type == UnitType.MINERAL_FIELD) | ((picked_type == UnitType.REFINERY) & own
                                                       & units.complete[safe]))
        self.unfinished_under = clicked & own & units.alive[safe] & ~units.complete[safe]
        self.unit_under = jnp.where(clicked, picked, NO_TARGET)


def apply_raw(state: EnvState, command: RawCommand, renderer: Renderer,
              card_table=CARD_TABLE, economy: bool = False) -> EnvState:
    """Applies one raw command: its units are selected (as PySC2's raw actions select
    them), then its function runs as a feature action would with that selection, at
    the command's world point or on its target unit, the camera moved to the point.
    Availability, results, `last_action` and `action_result` are the feature action's
    (`apply_action`)."""
    units = state.units
    mine = units.alive & (units.owner == Owner.SELF)
    state = state.replace(units=units.replace(selected=command.units & mine))
    action = jax.tree.map(jnp.asarray, zeros())._replace(function=command.function,
                                                        queued=command.queued)
    ctx = _Context.raw(state, command.point, command.target, renderer)
    return apply_action(state, action, renderer, card_table, economy, ctx)


class RawCommand(NamedTuple):
    """A command to units picked directly, with a world point or target unit (the raw
    interface's, and the built-in AI's).

    Attributes:
      function: int32 the feature function id of the command (`FUNCTIONS`).
      units: bool[N] the player's units commanded.
      point: float32[2] the world point targeted (and where the camera moves).
      target: int32 the unit slot targeted, or -1.
      queued: int32 0 (now) or 1 (queued).
    """

    function: jax.Array
    units: jax.Array
    point: jax.Array
    target: jax.Array
    queued: jax.Array


def apply_action(state: EnvState, action: DenseAction, renderer: Renderer,
                 card_table=CARD_TABLE, economy: bool = False,
                 context: _Context | None = None) -> EnvState:
    """Applies one (unbatched) dense action and records `last_action`/`action_result`.

    Each kind's branch returns (units, camera, result, bank, next_tag), where result
    is 0 or the `ActionResult` of its failure. `economy` (static) compiles the branches
    of production (building, training, rallies, cancels, idle workers); maps without it
    cannot make these functions available. `context`: a raw command's (`apply_raw`),
    in place of the action's screen and minimap points.
    """
    function = jnp.clip(action.function, 0, NUM_FUNCTIONS - 1)
    available = available_actions(state.units, card_table,
                                  state.researched if economy else None)[function]
    ctx = _Context(state, action, renderer) if context is None else context
    units = state.units
    a = action

    def attack_or(order):
        target = jnp.where(ctx.enemy_under, ctx.picked, NO_TARGET)
        kind = jnp.where(ctx.enemy_under, Order.ATTACK_UNIT, order)
        return commands.issue(units, kind, a.queued, ctx.point, target)

    bank, next_tag = jnp.stack([state.minerals, state.vespene]), state.next_tag
    makes = jnp.asarray(MAKES_TABLE)[function]

    def keep_camera(result):
        new_units, ok = result
        return (new_units, state.camera, jnp.where(ok, 0, int(ActionResult.Error)), bank,
                next_tag)

    def paid(new_units, result, new_bank=bank, new_tag=next_tag):
        return new_units, state.camera, result, new_bank, new_tag

    def gather():
        return commands.issue(units, Order.GATHER, a.queued, ctx.point, ctx.picked)

    def smart():
        # On a resource, workers gather; on an unfinished structure, SCVs resume its
        # construction; producers rally; the others move (or attack an enemy).
        moved, moved_ok = attack_or(Order.MOVE)
        worked, worked_ok = commands.issue(
            moved, jnp.where(ctx.resource_under, Order.GATHER, Order.CONSTRUCT), a.queued,
            ctx.point, ctx.picked)
        take = ctx.resource_under | ctx.unfinished_under
        smart_units = jax.tree_util.tree_map(lambda x, y: jnp.where(take, x, y), worked, moved)
        rallied, rallied_ok = production.set_rally(smart_units, ctx.point, ctx.unit_under)
        return rallied, moved_ok | (take & worked_ok) | rallied_ok

    def build():
        new_units, result = production.order_build(
            units, bank, renderer.buildable, makes, ctx.point,
            ctx.picked, a.queued)
        return paid(new_units, result)

    def train():
        new_units, new_bank, result = production.enqueue(units, bank, makes, state.researched)
        return paid(new_units, result, new_bank)

    def build_addon():
        new_units, new_bank, new_tag, result = production.build_addon(
            units, bank, next_tag, renderer.buildable, jnp.asarray(ADDON_TABLE)[function])
        return paid(new_units, result, new_bank, new_tag)

    def cancel():
        new_units, new_bank, new_tag, result = production.cancel_construction(
            units, bank, next_tag)
        return paid(new_units, result, new_bank, new_tag)

    def calldown_mule():
        new_units, new_tag, result = calldown.calldown_mule(units, ctx.point, ctx.unit_under,
                                                            next_tag)
        return paid(new_units, result, bank, new_tag)

    def cancel_queued(index):
        new_units, new_bank, result = production.cancel_queued(units, bank, index)
        return paid(new_units, result, new_bank)

    branches = [
        lambda: keep_camera((units, jnp.bool_(False))),  # UNSUPPORTED
        lambda: keep_camera((units, jnp.bool_(True))),  # NOOP
        lambda: (units, clamp_camera(renderer.geometry, ctx.minimap_point), jnp.int32(0),
                 bank, next_tag),
        lambda: keep_camera(ui.select_point(units, ctx.on_screen, ctx.picked,
                                            a.select_point_act)),
        lambda: keep_camera(ui.select_rect(units, ctx.pixel_pos, ctx.pixel_radius,
                                           ctx.on_screen, a.select_add, a.screen, a.screen2)),
        lambda: keep_camera(ui.control_group(units, a.control_group_act, a.control_group_id)),
        lambda: keep_camera(ui.select_unit(units, a.select_unit_act, a.select_unit_id)),
        lambda: keep_camera(ui.select_army(units, a.select_add)),
        lambda: keep_camera(attack_or(Order.ATTACK_MOVE)),
        lambda: keep_camera(commands.issue(units, Order.MOVE, a.queued, ctx.point)),
        lambda: keep_camera(commands.issue(units, Order.PATROL, a.queued, ctx.point)),
        lambda: keep_camera(smart()),
        lambda: keep_camera(commands.issue(units, Order.HOLD, a.queued, ctx.point)),
        lambda: keep_camera(commands.stop(units)),
        lambda: keep_camera(jax.lax.cond(ctx.resource_under, gather,
                                         lambda: (units, jnp.bool_(False)))),
        lambda: keep_camera(commands.issue(units, Order.RETURN, a.queued, ctx.point)),
        build,
        train,
        lambda: keep_camera(production.set_rally(units, ctx.point, ctx.unit_under)),
        cancel,
        lambda: cancel_queued(None),
        lambda: keep_camera(ui.select_idle_worker(units, a.select_worker)),
        lambda: cancel_queued(a.build_queue_id),
        build_addon,
        lambda: keep_camera(morphs.switch_mode(units, function)),
        lambda: paid(*liftoff.lift(units)),
        lambda: paid(*liftoff.order_land(units, renderer.buildable, ctx.point, a.queued)),
        lambda: keep_camera(research.stim(units, state.researched)),
        calldown_mule,
    ]
    if not economy:
        branches = branches[:Kind.BUILD]
    kind = jnp.where(available, jnp.asarray(KIND_TABLE)[function], Kind.UNSUPPORTED)
    kind = jnp.where(kind < len(branches), kind, Kind.UNSUPPORTED)
    new_units, camera, result, new_bank, new_tag = jax.lax.switch(
        kind, [lambda _, b=b: b() for b in branches], None)
    ok = result == 0
    executed = available & ok & (function != FUNCTIONS.no_op.id)
    result = jnp.where(available, result, int(ActionResult.NotSupported))
    spent, cumulative = bank - new_bank, state.score_cumulative
    return state.replace(
        units=new_units, camera=camera, minerals=new_bank[0], vespene=new_bank[1],
        next_tag=new_tag,
        score_cumulative=set_static(cumulative, {
            int(ScoreCumulative.spent_minerals): cumulative[ScoreCumulative.spent_minerals]
            + spent[0],
            int(ScoreCumulative.spent_vespene): cumulative[ScoreCumulative.spent_vespene]
            + spent[1]}),
        last_action=jnp.where(executed, function, -1).astype(jnp.int32),
        action_result=jnp.where(function == FUNCTIONS.no_op.id, 0, result).astype(jnp.int32))
