"""PySC2 function calls to StarCraft II API `Action` protos, and back.

`to_proto` is PySC2's `Features.transform_action` for the feature-layer action space
(reference/pysc2_facts.md §3): spatial parts go to `action_feature_layer`, the rest to
`action_ui`, enum index i becomes proto value i + 1, and ability functions send their
own ability id (the general one for general functions). `from_proto` inverts it, as
PySC2's `reverse_action` does with `hide_specific_actions`: a specific ability maps to
its general function, and an unknown ability to `no_op`.
"""

from __future__ import annotations

from sc2jax.environment.interface.functions import (
    FUNCTIONS,
    FunctionCall,
    FunctionType,
    function_for_ability,
)
from sc2jax.environment.sc2api.protos import sc2api

_T = FunctionType

VISIBLE_FUNCTION: dict[tuple[int, FunctionType], int] = {
    (f.ability_id, f.function_type): function_for_ability(f.ability_id, f.function_type)
    for f in FUNCTIONS if f.ability_id}
"""(ability id, function type) -> the function id a client sees with
`hide_specific_actions`: the general function of the same type, if the ability is a
specific one (every specific function has one), else its own."""


def to_proto(call: FunctionCall):
    """The `sc2api.Action` of a validated `FunctionCall` (`validate_function_call`)."""
    func = FUNCTIONS[call.function]
    args = [list(a) for a in call.arguments]
    action = sc2api.Action()
    spatial, ui = action.action_feature_layer, action.action_ui
    ftype = func.function_type
    if ftype == _T.no_op:
        pass
    elif ftype == _T.move_camera:
        _point(spatial.camera_move.center_minimap, args[0])
    elif ftype == _T.select_point:
        spatial.unit_selection_point.type = args[0][0] + 1
        _point(spatial.unit_selection_point.selection_screen_coord, args[1])
    elif ftype == _T.select_rect:
        rect = spatial.unit_selection_rect
        rect.selection_add = bool(args[0][0])
        corners = rect.selection_screen_coord.add()
        (x0, y0), (x1, y1) = args[1], args[2]
        _point(corners.p0, (min(x0, x1), min(y0, y1)))
        _point(corners.p1, (max(x0, x1), max(y0, y1)))
    elif ftype == _T.control_group:
        ui.control_group.action = args[0][0] + 1
        ui.control_group.control_group_index = args[1][0]
    elif ftype == _T.select_army:
        ui.select_army.selection_add = bool(args[0][0])
    elif ftype == _T.select_warp_gates:
        ui.select_warp_gates.selection_add = bool(args[0][0])
    elif ftype == _T.select_larva:
        ui.select_larva.SetInParent()
    elif ftype == _T.select_idle_worker:
        ui.select_idle_worker.type = args[0][0] + 1
    elif ftype == _T.select_unit:
        ui.multi_panel.type = args[0][0] + 1
        ui.multi_panel.unit_index = args[1][0]
    elif ftype == _T.unload:
        ui.cargo_panel.unit_index = args[0][0]
    elif ftype == _T.build_queue:
        ui.production_panel.unit_index = args[0][0]
    elif ftype == _T.autocast:
        ui.toggle_autocast.ability_id = func.ability_id
    else:  # cmd_quick, cmd_screen, cmd_minimap: queued first, then the target.
        command = spatial.unit_command
        command.ability_id = func.ability_id
        command.queue_command = bool(args[0][0])
        if ftype == _T.cmd_screen:
            _point(command.target_screen_coord, args[1])
        elif ftype == _T.cmd_minimap:
            _point(command.target_minimap_coord, args[1])
    return action


def from_proto(action) -> FunctionCall:
    """The `FunctionCall` a client sees for an `sc2api.Action` (no_op if unknown).

    Point arguments are the proto's coordinates, unchecked: validate them against the
    resolution (`validate_function_call`) before use.
    """
    spatial, ui = action.action_feature_layer, action.action_ui
    if action.HasField("action_feature_layer"):
        kind = spatial.WhichOneof("action")
        if kind == "unit_command":
            return _command(spatial.unit_command)
        if kind == "camera_move":
            return _call("move_camera", [_xy(spatial.camera_move.center_minimap)])
        if kind == "unit_selection_point":
            point = spatial.unit_selection_point
            return _call("select_point", [[max(point.type, 1) - 1],
                                          _xy(point.selection_screen_coord)])
        if kind == "unit_selection_rect" and spatial.unit_selection_rect.selection_screen_coord:
            rect = spatial.unit_selection_rect
            corners = rect.selection_screen_coord[0]
            return _call("select_rect", [[int(rect.selection_add)], _xy(corners.p0),
                                         _xy(corners.p1)])
    if action.HasField("action_ui"):
        kind = ui.WhichOneof("action")
        if kind == "control_group":
            return _call("select_control_group", [[max(ui.control_group.action, 1) - 1],
                                                  [ui.control_group.control_group_index]])
        if kind == "select_army":
            return _call("select_army", [[int(ui.select_army.selection_add)]])
        if kind == "select_warp_gates":
            return _call("select_warp_gates", [[int(ui.select_warp_gates.selection_add)]])
        if kind == "select_larva":
            return _call("select_larva", [])
        if kind == "select_idle_worker":
            return _call("select_idle_worker", [[max(ui.select_idle_worker.type, 1) - 1]])
        if kind == "multi_panel":
            return _call("select_unit", [[max(ui.multi_panel.type, 1) - 1],
                                         [ui.multi_panel.unit_index]])
        if kind == "cargo_panel":
            return _call("unload", [[ui.cargo_panel.unit_index]])
        if kind == "production_panel":
            return _call("build_queue", [[ui.production_panel.unit_index]])
        if kind == "toggle_autocast":
            fid = VISIBLE_FUNCTION.get((ui.toggle_autocast.ability_id, _T.autocast))
            return FunctionCall(fid, []) if fid is not None else _call("no_op", [])
    return _call("no_op", [])


def _command(command) -> FunctionCall:
    target = command.WhichOneof("target")
    ftype = {"target_screen_coord": _T.cmd_screen,
             "target_minimap_coord": _T.cmd_minimap}.get(target, _T.cmd_quick)
    fid = VISIBLE_FUNCTION.get((command.ability_id, ftype))
    if fid is None:
        return _call("no_op", [])
    args = [[int(command.queue_command)]]
    if ftype != _T.cmd_quick:
        args.append(_xy(getattr(command, target)))
    return FunctionCall(fid, args)


def _call(name: str, args: list[list[int]]) -> FunctionCall:
    return FunctionCall(FUNCTIONS[name].id, args)


def _point(proto, xy) -> None:
    proto.x, proto.y = int(xy[0]), int(xy[1])


def _xy(proto) -> list[int]:
    return [proto.x, proto.y]
