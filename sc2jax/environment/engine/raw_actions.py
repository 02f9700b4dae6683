"""The raw interface's actions in the simulator: a `raw.RawAction` becomes the
`actions.RawCommand` of the feature function that sends the same ability.

A raw function and its feature function send one SC2 ability, so the game runs them
alike: `raw_cmd` is the feature `*_quick`, `raw_cmd_pt` the `*_screen` on a world point,
`raw_cmd_unit` the `*_screen` on a unit, `raw_autocast` the `*_autocast`,
`raw_move_camera` is `move_camera`. The commanded units are selected first (PySC2 joins
with `raw_affects_selection`), except by `no_op` and `raw_move_camera`, which keep the
selection. The seven `UnloadUnit_*` raw functions have no feature function; the
simulator answers them `NotSupported`.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.actions import RawCommand, apply_raw
from sc2jax.environment.engine.availability import FEATURE_OF_RAW
from sc2jax.environment.engine.observation import rows_to_slots
from sc2jax.environment.engine.render import Renderer
from sc2jax.environment.engine.rules.state import NO_TARGET, EnvState
from sc2jax.environment.interface.functions import FUNCTIONS, RAW_FUNCTIONS
from sc2jax.environment.interface.functions import FunctionType as T
from sc2jax.environment.interface.protocol_enums import ActionResult
from sc2jax.environment.interface.raw import RawAction

SELECTS = np.array([r.function_type not in (T.raw_no_op, T.raw_move_camera)
                    for r in RAW_FUNCTIONS])
"""bool[564]: the raw functions that select their units (they take `unit_tags`)."""
TARGETS_UNIT = np.array([r.function_type == T.raw_cmd_unit for r in RAW_FUNCTIONS])


def raw_command(state: EnvState, action: RawAction, renderer: Renderer):
    """(`RawCommand`, bool supported): one (unbatched) raw action as the command of
    its feature function, its rows and target row resolved to the units of the
    `raw_units` this state is observed with."""
    units = state.units
    n = units.num_slots
    function = jnp.clip(action.function, 0, len(RAW_FUNCTIONS) - 1)
    feature = jnp.asarray(FEATURE_OF_RAW)[function]
    supported = feature >= 0
    slots = rows_to_slots(renderer.units_shown(state), action.units.shape[-1])
    commanded = jnp.zeros(n, bool).at[jnp.where(action.units & (slots >= 0), slots, n)].set(
        True, mode="drop")
    picked = jnp.where(action.target_unit >= 0,
                       slots[jnp.clip(action.target_unit, 0, slots.shape[0] - 1)], NO_TARGET)
    targets = jnp.asarray(TARGETS_UNIT)[function]
    target = jnp.where(targets, picked, NO_TARGET)
    point = jnp.where(targets & (target >= 0), units.pos[jnp.maximum(target, 0)],
                      renderer.raw_grid.pixel_to_world(action.world))
    return RawCommand(
        function=jnp.maximum(feature, FUNCTIONS.no_op.id),
        units=jnp.where(jnp.asarray(SELECTS)[function] & supported, commanded,
                        units.selected),
        point=point, target=target, queued=action.queued.astype(jnp.int32)), supported


def apply_raw_action(state: EnvState, action: RawAction, renderer: Renderer, card_table,
                     economy: bool) -> EnvState:
    """Applies one (unbatched) raw action (`actions.apply_raw` of its `raw_command`);
    a raw function without a feature function leaves the game as it is and reports
    `NotSupported`."""
    command, supported = raw_command(state, action, renderer)
    new = apply_raw(state, command, renderer, card_table, economy)
    return new.replace(action_result=jnp.where(
        supported, new.action_result, int(ActionResult.NotSupported)).astype(jnp.int32))
