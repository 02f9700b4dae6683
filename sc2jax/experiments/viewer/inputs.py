"""A person's mouse and keys in the viewer, as PySC2 function calls.

The page reports clicks in the pixels of its pictures: the human view (`HumanView` of
the playable area) and the minimap (`HumanView` of the whole map). `call_for_click` maps
them to world points, then to the screen's or the minimap's pixels through PySC2's
transforms (`interface.camera`), and builds the call a player's click means in the game:

| input | call |
|---|---|
| left click on the view | `select_point` (shift: toggle) |
| left drag on the view | `select_rect` (shift: add) |
| right click on the view | `Smart_screen` (shift: queued), else `Move_screen` |
| left click on the minimap | `move_camera` |
| right click on the minimap | `Smart_minimap` (shift: queued), else `Move_minimap` |
| a click after choosing a function with a point | that function at the point (shift: queued) |

Points on the view outside the camera's rectangle are off the screen: such a click is
refused, as the game would not take it (move the camera first).
"""

from __future__ import annotations

import numpy as np

from sc2jax.environment.engine.human_view import HumanView
from sc2jax.environment.interface.camera import Camera, Minimap
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall

KINDS = ("select", "rect", "smart", "point")
PANES = ("view", "minimap")


def view_to_world(view: HumanView, x: float, y: float) -> tuple[float, float]:
    """The world point under pixel (x, y) of a human view (pixel units, x right, y down)."""
    x0, _, _, y1 = view.region
    return x0 + x / view.scale, y1 - y / view.scale


def _screen_point(camera: Camera, centre, world, clip: bool = False) -> list[int]:
    """The screen pixel of a world point: off the screen, clipped to it with `clip` (a
    drag's corner may leave the screen), else refused."""
    px = camera.world_to_pixel(np.asarray(centre, np.float32),
                               np.asarray([world], np.float32))[0]
    w, h = camera.size
    if clip:
        return [int(np.clip(px[0], 0, w - 1)), int(np.clip(px[1], 0, h - 1))]
    if not (0 <= px[0] < w and 0 <= px[1] < h):
        raise ValueError(f"the point {tuple(round(v, 1) for v in world)} is off the screen "
                         f"(outside the camera's rectangle); move the camera there first")
    return [int(px[0]), int(px[1])]


def _minimap_point(minimap: Minimap, size, world) -> list[int]:
    px = minimap.world_to_pixel(np.asarray([world], np.float32))[0]
    return [int(np.clip(px[0], 0, size[0] - 1)), int(np.clip(px[1], 0, size[1] - 1))]


def call_for_click(click: dict, view: HumanView, minimap_view: HumanView, camera_centre,
                   available: np.ndarray) -> FunctionCall:
    """The call a click means (see the module's table).

    Args:
      click: {"pane": "view" | "minimap", "kind": one of KINDS, "x", "y" (pixels of the
        pane), and for "rect" "x2", "y2"; "shift" (bool); for "point" "function" (a
        function id or name with a screen or minimap point)}.
      view, minimap_view: the panes' human views.
      camera_centre: float32[2] the camera's world centre now.
      available: bool[573] the available functions.

    Raises:
      ValueError: for a bad click, a point off the screen, or no available function for it.
    """
    pane, kind = click.get("pane"), click.get("kind")
    if pane not in PANES or kind not in KINDS:
        raise ValueError(f"a click needs pane in {list(PANES)} and kind in {list(KINDS)}; "
                         f"got pane={pane!r}, kind={kind!r}")
    try:
        x, y = float(click["x"]), float(click["y"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"a click needs numeric x and y, got {click!r}") from None
    shift = bool(click.get("shift", False))
    sim = view.sim
    camera = Camera(sim.fmt.screen_size)
    minimap = Minimap(sim.fmt.minimap_size, sim.game.geometry.size)
    world = view_to_world(view if pane == "view" else minimap_view, x, y)

    def screen():
        return _screen_point(camera, camera_centre, world)

    def minimap_point(at=world):
        return _minimap_point(minimap, sim.fmt.minimap_size, at)

    if kind == "point":
        if click.get("function") not in FUNCTIONS:
            raise ValueError(f"unknown function {click.get('function')!r}")
        function = FUNCTIONS[click["function"]]
        args = []
        for arg in function.args:
            if arg.name in ("screen", "screen2"):
                if pane != "view":
                    raise ValueError(f"{function.name} takes a point on the screen: click "
                                     f"the view")
                args.append(screen())
            elif arg.name == "minimap":
                args.append(minimap_point())
            elif arg.name == "queued":
                args.append([int(shift)])
            else:
                args.append([0])
        return FunctionCall(function.id, args)
    if pane == "minimap":
        if kind == "select":
            return FUNCTIONS.move_camera(minimap_point())
        if kind == "smart":
            return _first_available(available, [
                (FUNCTIONS.Smart_minimap, [[int(shift)], minimap_point()]),
                (FUNCTIONS.Move_minimap, [[int(shift)], minimap_point()])])
        raise ValueError("drag to select on the view, not on the minimap")
    if kind == "select":
        return FUNCTIONS.select_point("toggle" if shift else "select", screen())
    if kind == "smart":
        return _first_available(available, [
            (FUNCTIONS.Smart_screen, [[int(shift)], screen()]),
            (FUNCTIONS.Move_screen, [[int(shift)], screen()])])
    try:
        corner = view_to_world(view, float(click["x2"]), float(click["y2"]))
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"a rect click needs numeric x2 and y2, got {click!r}") from None
    a, b = (_screen_point(camera, camera_centre, p, clip=True) for p in (world, corner))
    return FUNCTIONS.select_rect(int(shift), [min(a[0], b[0]), min(a[1], b[1])],
                                 [max(a[0], b[0]), max(a[1], b[1])])


def _first_available(available, options) -> FunctionCall:
    for function, args in options:
        if available[function.id]:
            return FunctionCall(function.id, args)
    names = [function.name for function, _ in options]
    raise ValueError(f"none of {names} is available now: select a unit first")
