"""Frames of episodes: the human view beside colour panels of feature layers, captioned.

`Pictures` draws, in one jitted call over an episode's states and observations, the
human view (`engine.human_view`) and each chosen layer in PySC2's colours
(`interface.palettes`). `compose` lays one step's pictures out as one frame with PIL: the
human view on the left, the layer panels in a grid on the right, each with its name and
a legend (the categorical values on screen, or the heat map's range), and text below:
the map, the step and game loop, the score so far and the action taken. `grid` tiles
the human views of a batch of environments.

`episode_pictures` replays a recorded `Episode` and draws it; `episode_frames` and
`batch_frames` lay its pictures out as frames, which `viewer.video` writes as a video.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from typing import NamedTuple

import jax
import numpy as np
from PIL import Image, ImageDraw, ImageFont

from sc2jax.environment.engine.human_view import HumanView
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.episodes import Episode, replay_whole
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.dense import DenseAction, from_dense
from sc2jax.environment.interface.features import MINIMAP_FEATURES, SCREEN_FEATURES, Feature
from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.environment.interface.palettes import colorize, legend, palette

DEFAULT_LAYERS = ("screen/player_relative", "screen/unit_type", "screen/selected",
                  "minimap/player_relative")
"""The layers shown beside the human view unless others are asked for."""

UNIT_NAMES = {int(UNIT_DATA.sc2_id[t]): t.name.title().replace("_", "")
              for t in UnitType if t != UnitType.NONE}
"""StarCraft II unit id -> name, for the `unit_type` legends (the simulator's types)."""

CHUNK = 64
"""Steps drawn in one call by `episode_pictures`."""

_BACKGROUND = (16, 16, 20)
_TEXT = (230, 230, 230)


def parse_layers(names: Sequence[str]) -> tuple[Feature, ...]:
    """The features named "screen/<layer>" or "minimap/<layer>", in order.

    Raises:
      ValueError: for a name of another form or an unknown layer.
    """
    sets = {"screen": SCREEN_FEATURES, "minimap": MINIMAP_FEATURES}
    out = []
    for name in names:
        layer_set, _, layer = str(name).partition("/")
        if layer_set not in sets or layer not in sets[layer_set]._fields:
            allowed = [f"{s}/{f}" for s, fs in sets.items() for f in fs._fields]
            raise ValueError(f"unknown layer {name!r}; give 'screen/<name>' or "
                             f"'minimap/<name>', one of {allowed}")
        out.append(getattr(sets[layer_set], layer))
    return tuple(out)


def layer_format(screen_size, minimap_size, layers: Sequence[Feature]
                 ) -> specs.ObservationFormat:
    """The observation format that renders only `layers` (at least one of each set, as
    the format needs)."""
    screen = [f.name for f in layers if f.layer_set == "screen"] or ["player_relative"]
    minimap = [f.name for f in layers if f.layer_set == "minimap"] or ["player_relative"]
    return specs.ObservationFormat(screen_size=screen_size, minimap_size=minimap_size,
                                   screen_features=tuple(screen),
                                   minimap_features=tuple(minimap))


@dataclasses.dataclass(frozen=True, eq=False)
class Pictures:
    """The human view and layer panels of states (a static config; call it jitted).

    Args:
      sim: the simulator the states come from; its format must render `layers`.
      width: the human view's width in pixels.
      layers: the feature layers to colour.
    """

    sim: Simulator
    width: int = 256
    layers: tuple[Feature, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "view", HumanView(self.sim, self.width))
        fmt = self.sim.fmt
        channels = {}
        for feature in self.layers:
            drawn = fmt.screen_layers if feature.layer_set == "screen" else fmt.minimap_layers
            if feature not in drawn:
                raise ValueError(f"the simulator's format does not render "
                                 f"{feature.layer_set}/{feature.name}")
            channels[feature] = drawn.index(feature)
        object.__setattr__(self, "channels", channels)

    def __call__(self, state, observation):
        """(view uint8[H, W, 3], panels [uint8[h, w, 3]], values [int32[h, w]]) of one
        state and its padded observation: the human view, and each layer coloured and as
        it is; vmap it over steps or environments."""
        values = [observation["feature_screen" if f.layer_set == "screen"
                              else "feature_minimap"][self.channels[f]] for f in self.layers]
        return (self.view.draw(state), [colorize(v, f) for v, f in zip(values, self.layers)],
                values)

    @functools.cached_property
    def batched(self):
        """jit(vmap(self)): over a leading axis of states and observations."""
        return jax.jit(jax.vmap(self))


def _font(size: int = 11):
    return ImageFont.load_default(size=size)


def action_text(action: DenseAction) -> str:
    """One unbatched dense action as PySC2 writes a call: `Move_screen(0, [23, 40])`."""
    call = from_dense(action)
    args = ", ".join(str([int(v) for v in a]) if len(a) > 1 else str(int(a[0]))
                     for a in call.arguments)
    return f"{FUNCTIONS[int(call.function)].name}({args})"


def compose(view: np.ndarray, panels: Sequence[np.ndarray], layers: Sequence[Feature],
            text: str, values: Sequence[np.ndarray] = (), panel_size: int = 128
            ) -> np.ndarray:
    """uint8[H', W', 3]: one frame: the human view, the layer panels in a grid of two
    rows to its right (each `panel_size` pixels square), each captioned with its layer
    and, given the layers' `values`, a legend (its categorical values, or the heat map's
    range); and below, `text` (lines split at newlines, each cut to the frame's width).
    The frame's size depends only on the view's, the panels' count and size, and the
    text's line count."""
    font = _font()
    line = 14
    vh, vw = view.shape[:2]
    lines = text.split("\n")
    columns = -(-len(panels) // 2)
    cell_w, cell_h = panel_size + 8, panel_size + 2 * line + 4
    height = max(vh, min(len(panels), 2) * cell_h) + line * len(lines) + 6
    width = vw + 4 + columns * cell_w
    frame = Image.new("RGB", (width, height), _BACKGROUND)
    frame.paste(Image.fromarray(np.asarray(view)), (0, 0))
    draw = ImageDraw.Draw(frame)
    for i, (panel, feature) in enumerate(zip(panels, layers)):
        x, y = vw + 4 + (i // 2) * cell_w, (i % 2) * cell_h
        draw.text((x, y + 1), _fit(f"{feature.layer_set}/{feature.name}", font, cell_w,
                                   keep_end=True), font=font, fill=_TEXT)
        image = Image.fromarray(np.asarray(panel)).resize((panel_size, panel_size),
                                                          Image.NEAREST)
        frame.paste(image, (x, y + line + 2))
        if i < len(values):
            _draw_legend(draw, font, feature, values[i], x, y + line + panel_size + 4,
                         x + cell_w)
    for k, t in enumerate(lines):
        draw.text((4, height - line * (len(lines) - k) - 3), _fit(t, font, width - 4),
                  font=font, fill=_TEXT)
    return np.asarray(frame)


def _fit(text: str, font, width: int, keep_end: bool = False) -> str:
    """`text`, shortened with an ellipsis to fit in `width` pixels: its end cut, or with
    `keep_end` its start."""
    while len(text) > 4 and font.getlength(text) > width - 4:
        text = "…" + text[2:] if keep_end else text[:-2] + "…"
    return text


def layer_legend(feature: Feature, values: np.ndarray) -> list:
    """(value, colour, label) of each non-zero value on a categorical layer (int [...]),
    ascending; unit types named."""
    names = UNIT_NAMES if feature.name == "unit_type" else None
    return legend(feature, [v for v in np.unique(values) if v != 0], names)


def _draw_legend(draw, font, feature, values, x, y, right):
    """A layer's legend on one line from x to `right`: a categorical layer's non-zero
    values (as many as fit) as coloured squares and labels; a scalar layer's heat map
    from 0 to its scale."""
    if not feature.is_categorical:
        bar = palette(feature)
        for k in range(40):
            draw.line([x + k, y + 2, x + k, y + 9],
                      fill=tuple(int(c) for c in bar[k * (len(bar) - 1) // 39]))
        draw.text((x + 44, y), f"0 to {feature.scale}", font=font, fill=_TEXT)
        return
    for _, rgb, label in layer_legend(feature, values):
        end = x + 14 + int(draw.textlength(label, font=font))
        if end > right:
            break
        draw.rectangle([x, y + 2, x + 7, y + 9], fill=rgb)
        draw.text((x + 10, y), label, font=font, fill=_TEXT)
        x = end


def grid(views: np.ndarray, captions: Sequence[str] = (), columns: int | None = None
         ) -> np.ndarray:
    """uint8[...]: the human views (uint8[B, H, W, 3]) of a batch tiled in a grid, each
    with its caption."""
    views = np.asarray(views)
    b, h, w = views.shape[:3]
    columns = columns or int(np.ceil(np.sqrt(b)))
    rows = -(-b // columns)
    caption = 14 if captions else 0
    frame = Image.new("RGB", (columns * (w + 2), rows * (h + caption + 2)), _BACKGROUND)
    draw = ImageDraw.Draw(frame)
    font = _font()
    for i in range(b):
        x, y = (i % columns) * (w + 2), (i // columns) * (h + caption + 2)
        frame.paste(Image.fromarray(views[i]), (x, y))
        if captions:
            draw.text((x + 2, y + h), captions[i], font=font, fill=_TEXT)
    return np.asarray(frame)


@functools.cache
def pictures(sim: Simulator, width: int, layers: tuple[Feature, ...]) -> Pictures:
    """One `Pictures` (and so one compiled program) per simulator, width and layers."""
    return Pictures(sim, width, layers)


class EpisodePictures(NamedTuple):
    """An episode's pictures, each with a leading [T + 1] axis (numpy).

    Attributes:
      views: uint8[T + 1, H, W, 3] the human view.
      panels: uint8[T + 1, h, w, 3] per layer, the layer coloured.
      values: int32[T + 1, h, w] per layer, the layer's values.
      scores: float64[T + 1] the score after each step (0 at the reset).
    """

    views: np.ndarray
    panels: list[np.ndarray]
    values: list[np.ndarray]
    scores: np.ndarray


def episode_pictures(episode: Episode, width: int = 256,
                     layers: Sequence[Feature] = ()) -> EpisodePictures:
    """The pictures of a recorded episode, replayed with only `layers` rendered."""
    fmt = layer_format(episode.screen_size, episode.minimap_size, layers)
    states, timesteps = replay_whole(episode, fmt)
    draw = pictures(episode.simulator(fmt), width, tuple(layers)).batched
    end = episode.num_steps + 1
    # Drawn CHUNK steps at a time (one compiled size; the last chunk padded), so that
    # the memory does not grow with the episode.
    chunks = []
    for start in range(0, end, CHUNK):
        index = np.minimum(np.arange(start, start + CHUNK), end - 1)
        chunk = jax.tree.map(lambda x, i=index: x[i], (states, timesteps.observation))
        chunks.append(jax.device_get(draw(*chunk)))
    views, panels, values = jax.tree.map(lambda *xs: np.concatenate(xs)[:end], *chunks)
    return EpisodePictures(views, panels, values,
                           np.cumsum(np.asarray(timesteps.reward), dtype=np.float64))


def step_text(episode: Episode, t: int, score: float) -> str:
    """The caption of step t: map, step, game loop and score so far; and on a second
    line the action taken."""
    text = (f"{episode.map_name}   step {t}/{episode.num_steps}   game loop "
            f"{t * episode.step_mul}   score {score:g}")
    if t < episode.num_steps:
        action = DenseAction(*(np.asarray(a[t]) for a in episode.actions))
        return text + f"\naction {action_text(action)}"
    return text + "\nthe episode is over"


def episode_frames(episode: Episode, drawn: EpisodePictures, layers: Sequence[Feature]
                   ) -> list[np.ndarray]:
    """The frames of a recorded episode, one per observation (T + 1), from its pictures
    (`episode_pictures` with the same `layers`)."""
    return [compose(drawn.views[t], [p[t] for p in drawn.panels], layers,
                    step_text(episode, t, drawn.scores[t]), [v[t] for v in drawn.values])
            for t in range(episode.num_steps + 1)]


def batch_frames(drawn: Sequence[EpisodePictures]) -> list[np.ndarray]:
    """Frames of several episodes side by side: a grid of their human views (from
    `episode_pictures`, all of one map and width), each captioned with its score; an
    episode that ended shows its last picture."""
    ends = [len(d.views) - 1 for d in drawn]
    return [grid(np.stack([d.views[min(t, e)] for d, e in zip(drawn, ends)]),
                 [f"score {d.scores[min(t, e)]:g}" for d, e in zip(drawn, ends)])
            for t in range(max(ends) + 1)]
