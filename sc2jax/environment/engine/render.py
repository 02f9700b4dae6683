"""Feature-layer rendering: the screen and minimap layers of PySC2 v4 from the state.

A unit covers every pixel whose centre lies within its radius, and always the pixel that
contains its centre (`paint`). Where units overlap, the one drawn on top (ground units over
structures over resources over beacons, then the higher slot) gives the categorical and
per-unit values; `unit_density` counts all of them. Only the layers the observation
format asks for are computed.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.rules import research
from sc2jax.environment.engine.rules.geometry import MapGeometry, cell_lookup, squared_length
from sc2jax.environment.engine.rules.state import EnvState, Owner, Units, leading_slots
from sc2jax.environment.engine.rules.units import UNIT_DATA, Attribute, UnitType
from sc2jax.environment.engine.xla.fusion import materialize
from sc2jax.environment.interface.camera import Camera, Minimap, RawGrid
from sc2jax.environment.interface.feature_units import ratio_255
from sc2jax.environment.interface.features import DENSITY, PlayerRelative, Visibility
from sc2jax.environment.interface.specs import ObservationFormat

# Drawing order: higher layers are drawn over lower ones: resources, structures, ground
# units, flying units and lifted structures (the beacon, which has no health, under all).
_STRUCTURE = (UNIT_DATA.attributes & Attribute.STRUCTURE) > 0
_RESOURCE = (UNIT_DATA.contents > 0) | (np.arange(len(UnitType)) == UnitType.MINERAL_SHARD)
_RENDER_LAYER = np.select(
    [_RESOURCE, UNIT_DATA.flying, _STRUCTURE, UNIT_DATA.max_health > 0], [1, 4, 2, 3],
    0).astype(np.int32)

_PLAYER_RELATIVE = {Owner.SELF: PlayerRelative.SELF, Owner.ENEMY: PlayerRelative.ENEMY,
                    Owner.NEUTRAL: PlayerRelative.NEUTRAL}


FIELD_BITS = {
    "unit_type": 11,
    "player_relative": 3,
    "player_id": 5,
    "selected": 1,
    "unit_hit_points_ratio": 8,
    "unit_hit_points": 13,
    "unit_energy": 10,
    "unit_energy_ratio": 8,
    "unit_shields": 11,
    "unit_shields_ratio": 8,
    "build_progress": 8,
}
"""Per-unit layer -> the bits of its field in the packed per-unit words (`pack_fields`).
Values beyond a field's bits are clipped (hit points at 8191, energy at 1023, shields at
2047; no unit reaches these)."""

TERRAIN_PACKING = {
    "height_map": (0, 8),
    "pathable": (8, 1),
    "buildable": (9, 1),
    "visibility_map": (10, 2),
    "camera": (12, 1),
}
"""Map layer -> (bit shift, bits) in the packed map plane of a view."""

STATIC_TERRAIN = ("height_map", "pathable", "buildable")
"""Map layers read from the map's static grids alone: the same in every observation of a
view that never moves (the minimap)."""



def player_relative(owner):
    """int32[N] `PlayerRelative` of each owner."""
    out = jnp.zeros_like(owner)
    for o, rel in _PLAYER_RELATIVE.items():
        out = jnp.where(owner == o, int(rel), out)
    return out


def paint(pixel_pos, pixel_radius, keys, shown, size, box: int, with_density: bool = False):
    """Draws units as discs on a pixel grid, keeping the highest key at each pixel.

    A unit covers the pixels whose centres lie within its radius, and always the pixel
    holding its centre. Each unit is drawn inside a `box` x `box` window around its
    centre pixel (box must cover the largest radius): one scatter for all the keys, and
    one for the density.

    Args:
      pixel_pos: float32[N, 2] continuous pixel coordinates (x, y) of unit centres.
      pixel_radius: float32[N] radii in pixels.
      keys: a list of int32[N] >= 0: what each unit writes, one canvas per key. A pixel
        keeps the highest key of the units covering it, and 0 where none does.
      shown: bool[N] units that may be drawn.
      size: (width, height) in pixels.
      box: odd window size, >= `box_size(max radius)`.
      with_density: also count the units covering each pixel.

    Returns:
      (list of int32[H, W], one per key; density [H, W] or None: int16 for N < 2^15,
      else int32).
    """
    w, h = size
    offsets = jnp.arange(box) - box // 2
    cx = jnp.floor(pixel_pos[:, 0]).astype(jnp.int32)
    cy = jnp.floor(pixel_pos[:, 1]).astype(jnp.int32)
    px = cx[:, None] + offsets[None, :]
    py = cy[:, None] + offsets[None, :]
    dx = px.astype(jnp.float32) + 0.5 - pixel_pos[:, 0:1]
    dy = py.astype(jnp.float32) + 0.5 - pixel_pos[:, 1:2]
    centre = (offsets[:, None] == 0) & (offsets[None, :] == 0)
    inside = (dy[:, :, None] ** 2 + dx[:, None, :] ** 2
              <= (pixel_radius * pixel_radius)[:, None, None]) | centre[None]
    in_bounds = ((py >= 0) & (py < h))[:, :, None] & ((px >= 0) & (px < w))[:, None, :]
    drawn = inside & in_bounds & shown[:, None, None]
    # One scatter paints every key, into the rows of one [K, h * w] canvas; pixels not
    # drawn go past the row's end and are dropped. A zero canvas of its own per key would
    # be one zero array copied per scatter (XLA merges equal zero arrays, and a scatter
    # writes its operand in place); rows of exactly h * w are [H, W] planes without a
    # copy (docs/benchmarks.md).
    hw = h * w
    index = jnp.where(drawn, py[:, :, None] * w + px[:, None, :], hw).reshape(-1)
    canvases = []
    if keys:
        # The keys computed once per unit, not once per pixel of its window.
        per_unit = materialize(jnp.stack(keys))
        values = jnp.broadcast_to(per_unit[:, :, None, None],
                                  (len(keys),) + drawn.shape).reshape(len(keys), -1)
        canvas = jnp.zeros((len(keys), hw), jnp.int32).at[:, index].max(values, mode="drop")
        canvases = list(canvas.reshape(len(keys), h, w))
    density = None
    if with_density:
        # Counted in int16 where the N units cannot overflow it: half the bytes, and a
        # zero canvas of its own, not a copy of the keys' int32 one.
        count = jnp.int16 if pixel_pos.shape[0] < 2 ** 15 else jnp.int32
        density = jnp.zeros((hw,), count).at[index].add(1, mode="drop").reshape(h, w)
    return canvases, density


def pack_fields(names, word_bits: int) -> dict[str, tuple[int, int, int]]:
    """Packs the named per-unit layers' fields (`FIELD_BITS`) into words of `word_bits`.

    Fields go into the words in `FIELD_BITS` order, each into the first word with room.

    Returns:
      name -> (word, bit shift, bits).

    Raises:
      ValueError: a field is wider than a word (word_bits shrinks as the draw rank
        needs more bits: with more than 32,768 unit slots).
    """
    packing, used = {}, []
    for name, bits in FIELD_BITS.items():
        if name not in names:
            continue
        if bits > word_bits:
            raise ValueError(f"the {name} field ({bits} bits) does not fit in a {word_bits}-bit "
                             f"word; allowed: word_bits >= {max(FIELD_BITS.values())}")
        word = next((k for k, u in enumerate(used) if u + bits <= word_bits), len(used))
        if word == len(used):
            used.append(0)
        packing[name] = (word, used[word], bits)
        used[word] += bits
    return packing


def paints_every_word(num_slots: int, box: int, size) -> bool:
    """Whether `Renderer` paints every packed word, or only the first.

    Each `paint` key costs a scatter of N * box^2 values. Where that is more than half
    the pixels (large units, many slots), only the first word is painted, and the
    others are looked up by the top unit's slot, which the first word's key holds.
    """
    return num_slots * box * box <= size[0] * size[1] // 2


def eyes(units: Units, own_slots: int | None = None):
    """Where the player's units look from: (pos float32[M, 2], reach float32[M]).

    M is `own_slots` (the leading slots that can hold the player's units,
    `MiniGame.own_slots`) or, for None, all N slots. `reach` is the squared sight radius
    of each of the player's live units and -1 elsewhere: no point is within -1 of
    anything.
    """
    units = leading_slots(units, own_slots)
    sight = jnp.asarray(UNIT_DATA.sight)[units.type]
    looks = units.alive & (units.owner == Owner.SELF)
    return units.pos, jnp.where(looks, sight * sight, -1.0)


UNROLLED_EYES = 64
"""Up to this many eyes `sight_grid` tests every pixel against each (unrolled); beyond,
it marks each eye's row intervals (measured on the 2-core CPU: 64 eyes over 64² and
176² grids are up to 2x faster unrolled, 256 eyes over 64² 4x faster by intervals, 768
over a melee map's 176 × 184 cells 17x)."""
MAX_SIGHT = float(np.max(UNIT_DATA.sight))


def sight_grid(units: Units, xs, ys, spacing: float, own_slots: int | None = None):
    """bool[H, W]: the points (xs[j], ys[i]) within sight of one of the player's units:
    where (xs[j] - x)² + (ys[i] - y)² <= sight² for a unit at (x, y).

    Args:
      units: the units.
      xs: float32[W] world x of each column, increasing by `spacing`.
      ys: float32[H] world y of each row, decreasing by `spacing`.
      spacing: (static) world units between adjacent pixel centres.
      own_slots: (static) None, or the number of leading slots that can hold the
        player's units (`MiniGame.own_slots`); only those are looked through.
    """
    pos, reach = eyes(units, own_slots)
    if len(reach) <= UNROLLED_EYES:
        return _sight_unrolled(pos, reach, xs, ys)
    return _sight_intervals(pos, reach, xs, ys, spacing)


def _sight_unrolled(pos, reach, xs, ys):
    """`sight_grid` one eye at a time over [H, W] (the loop is unrolled): under `vmap`
    this stays elementwise over [B, H, W], where an [M, H, W] reduction would be
    transposed."""
    # Each eye's squared distances along the columns and rows, computed once, not per
    # pixel.
    dx2 = materialize((xs[None, :] - pos[:, 0, None]) ** 2)
    dy2 = materialize((ys[None, :] - pos[:, 1, None]) ** 2)
    reach = materialize(reach)
    seen = jnp.zeros((ys.shape[0], xs.shape[0]), bool)
    for i in range(len(reach)):
        seen = seen | (dy2[i][:, None] + dx2[i][None, :] <= reach[i])
    return seen


def _sight_intervals(pos, reach, xs, ys, spacing: float):
    """`sight_grid` by row intervals: each eye sees a run of columns in each of the
    2K + 1 rows around it (K from the longest sight); a run's start adds 1 and its end
    subtracts 1 in an [H, W + 1] grid, whose running sum along rows is > 0 where seen.
    A run's ends come from the circle's half-width, then are moved by one where the
    pixel test (the same float arithmetic as `_sight_unrolled`'s) says otherwise, so
    both give the same pixels."""
    xs, ys = jnp.asarray(xs), jnp.asarray(ys)
    h, w = ys.shape[0], xs.shape[0]
    half = int(np.ceil(MAX_SIGHT / spacing)) + 1
    if 2 * half + 1 < h:
        nearest = jnp.round((ys[0] - pos[:, 1]) / spacing).astype(jnp.int32)
        rows = nearest[:, None] + jnp.arange(-half, half + 1)[None, :]  # [M, K]
    else:
        rows = jnp.broadcast_to(jnp.arange(h), (len(reach), h))
    dy2 = (ys[jnp.clip(rows, 0, h - 1)] - pos[:, 1, None]) ** 2
    room = reach[:, None] - dy2
    half_width = jnp.sqrt(jnp.maximum(room, 0.0))
    x = pos[:, 0, None]

    def sees(column):
        return dy2 + (xs[jnp.clip(column, 0, w - 1)] - x) ** 2 <= reach[:, None]

    lo = jnp.clip(jnp.ceil((x - half_width - xs[0]) / spacing).astype(jnp.int32), 0, w - 1)
    hi = jnp.clip(jnp.floor((x + half_width - xs[0]) / spacing).astype(jnp.int32), 0, w - 1)
    lo = jnp.where((lo > 0) & sees(lo - 1), lo - 1, jnp.where(sees(lo), lo, lo + 1))
    hi = jnp.where((hi < w - 1) & sees(hi + 1), hi + 1, jnp.where(sees(hi), hi, hi - 1))
    rows = jnp.where((room >= 0) & (lo <= hi) & (rows >= 0) & (rows < h), rows, h)
    marks = jnp.zeros((h, w + 1), jnp.int32)
    marks = marks.at[rows, lo].add(1, mode="drop").at[rows, hi + 1].add(-1, mode="drop")
    return jnp.cumsum(marks[:, :w], axis=1) > 0


def _runs(mask) -> list[tuple[int, int]]:
    """The (start, stop) of each run of adjacent True entries of a bool sequence."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask, np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def box_size(max_radius_pixels: float) -> int:
    """The window `paint` needs for units up to this radius (in pixels).

    A unit whose centre lies at a fraction f in [0, 1) of its pixel along an axis
    reaches the pixel k to that side only if |k + 0.5 - f| <= r, so k lies in
    [-floor(r + 0.5), ceil(r + 0.5) - 1]: a window of 2 * floor(r + 0.5) + 1 pixels
    (3 for the screen's marines and zerglings at 64², 1 on the 64² minimap). The small
    margin keeps a radius that rounds just below a half-integer in float32 inside.
    """
    return 2 * int(np.floor(max_radius_pixels + 0.5 + 1e-4)) + 1


def slot_bits(num_slots: int) -> int:
    """The bits of a slot index in a `draw_rank`."""
    return max(num_slots - 1, 1).bit_length()


def draw_rank(units: Units):
    """int32[N]: drawing priority, distinct, higher on top: the render layer, then the
    slot (in the low `slot_bits`). Below `rank_bound(N)`."""
    n = units.num_slots
    return ((jnp.asarray(_RENDER_LAYER)[units.type] << slot_bits(n))
            | jnp.arange(n, dtype=jnp.int32))


def rank_bound(num_slots: int) -> int:
    """The bound of `draw_rank` for this many slots."""
    return int(_RENDER_LAYER.max() + 1) << slot_bits(num_slots)


def rank_slot(rank, num_slots: int):
    """The slot of a `draw_rank` (int32, any shape)."""
    return rank & ((1 << slot_bits(num_slots)) - 1)


def pick_unit(units: Units, shown, pixel_pos, pixel_radius, pixel):
    """The slot drawn on top at one pixel (int32[2] x, y), or -1: what a click selects."""
    dx = pixel[0].astype(jnp.float32) + 0.5 - pixel_pos[:, 0]
    dy = pixel[1].astype(jnp.float32) + 0.5 - pixel_pos[:, 1]
    inside = dx * dx + dy * dy <= pixel_radius * pixel_radius
    at_centre = ((jnp.floor(pixel_pos[:, 0]).astype(jnp.int32) == pixel[0])
                 & (jnp.floor(pixel_pos[:, 1]).astype(jnp.int32) == pixel[1]))
    cover = (inside | at_centre) & shown
    best = jnp.max(jnp.where(cover, draw_rank(units), -1))
    return jnp.where(best >= 0, rank_slot(best, units.num_slots), -1)


class Renderer:
    """Renders the layers an `ObservationFormat` asks for, for one map.

    Args:
      fmt: the observation format (resolutions and layer subsets).
      geometry: the map's static layout.
      fog: whether the map has fog of war (else the playable area is revealed).
      max_radius: the largest unit radius on the map, world units.
      zero_layers: per-unit layers that are zero for every unit type on the map (map
        layers that are zero everywhere are added to them).
      cheat_layers: fill the minimap `unit_type` layer (PySC2's `allow_cheating_layers`).
      own_slots: None, or the number of leading slots that can hold the player's units
        (`MiniGame.own_slots`): fog of war looks through those alone.
    """

    def __init__(self, fmt: ObservationFormat, geometry: MapGeometry, fog: bool,
                 max_radius: float, zero_layers=(), cheat_layers: bool = False,
                 own_slots: int | None = None):
        self.fmt = fmt
        self.own_slots = own_slots
        self.geometry = geometry
        self.fog = fog
        self.cheat_layers = cheat_layers
        self.camera = Camera(fmt.screen_size)
        self.minimap = Minimap(fmt.minimap_size, geometry.size)
        self.raw_grid = RawGrid(fmt.raw_resolution or geometry.size, geometry.size)
        # A map layer that is zero over the whole map (`height_map` on the flat maps) is
        # zero in every view, however the camera moves: a zero layer too.
        self.zero_layers = frozenset(zero_layers) | {
            name for name in STATIC_TERRAIN if not np.any(getattr(geometry, name))}
        # The map's buildable cells as a device array made here, outside any trace: one
        # made while tracing is a tracer, which a step's programs must not keep.
        self.buildable = jnp.asarray(geometry.buildable)
        self.screen_box = box_size(max_radius * self.camera.pixels_per_unit)
        self.minimap_box = box_size(max_radius * self.minimap.pixels_per_unit)

    # Per-unit visibility and attributes.

    def units_shown(self, state: EnvState):
        """bool[N]: units the player can see (own units always; others when visible)."""
        units = state.units
        own = units.owner == Owner.SELF
        if not self.fog:
            return units.alive
        seen = self.visible_points(state, units.pos)
        return units.alive & (own | seen)

    def visible_points(self, state: EnvState, xy):
        """bool[...]: world points within sight of one of the player's units."""
        pos, reach = eyes(state.units, self.own_slots)
        return jnp.any(squared_length(xy[..., None, :] - pos) <= reach, axis=-1)

    def _visibility(self, state: EnvState, xs, ys, spacing, in_play):
        """int32[H, W] visibility of world columns xs and rows ys, `spacing` apart
        (in_play: bool[H, W])."""
        if not self.fog:
            return jnp.where(in_play, int(Visibility.VISIBLE), int(Visibility.HIDDEN))
        visible = sight_grid(state.units, xs, ys, spacing, self.own_slots)
        explored = cell_lookup(state.explored, self.geometry.size[1], xs, ys, False)
        out = jnp.where(visible, int(Visibility.VISIBLE),
                        jnp.where(explored, int(Visibility.SEEN), int(Visibility.HIDDEN)))
        return jnp.where(in_play, out, int(Visibility.HIDDEN)).astype(jnp.int32)

    def _terrain_plane(self, state: EnvState, xs, ys, spacing, names, extra_bits: dict):
        """int32[H, W]: the map layers of one view packed into one plane (`TERRAIN_PACKING`).

        The static grids are packed into one grid first, so the view needs one lookup.
        """
        g = self.geometry
        plane = None
        if {"height_map", "pathable", "buildable"} & set(names):
            packed = (g.height_map.astype(np.int32)
                      | (g.pathable.astype(np.int32) << TERRAIN_PACKING["pathable"][0])
                      | (g.buildable.astype(np.int32) << TERRAIN_PACKING["buildable"][0]))
            plane = cell_lookup(packed, g.size[1], xs, ys, 0)
        if "visibility_map" in names:
            x0, y0, x1, y1 = g.playable
            in_play = ((ys >= y0) & (ys < y1))[:, None] & ((xs >= x0) & (xs < x1))[None, :]
            visibility = self._visibility(state, xs, ys, spacing, in_play)
            shifted = visibility.astype(jnp.int32) << TERRAIN_PACKING["visibility_map"][0]
            plane = shifted if plane is None else plane | shifted
        for name, bits in extra_bits.items():
            if name in names:
                shifted = bits().astype(jnp.int32) << TERRAIN_PACKING[name][0]
                plane = shifted if plane is None else plane | shifted
        return plane

    def _draw(self, state: EnvState, names, size, pixel_pos, pixel_radius, box, xs, ys,
              spacing: float, extra_bits: dict, previous=None):
        """Renders the named layers of one view (screen or minimap).

        Every layer is a bit field of one of a few int32 planes: the packed per-unit words
        of the top unit at each pixel (`pack_fields`), the unit density, and the packed map
        layers (`TERRAIN_PACKING`). The planes are computed once and the layers are cut
        out of them in one pass that writes the output directly.

        With `previous`, the layers that are the same in every observation (zero layers,
        and where the view never moves, xs and ys numpy: `STATIC_TERRAIN`, and the
        visibility of a map without fog) are kept from it, and the others are written
        into it, one `dynamic_update_slice` per run of adjacent layers: inside a jitted
        loop that carries the observation, XLA updates its buffer in place and the kept
        layers cost nothing.

        Args:
          state: the state.
          names: the layer names, in output order (unknown names are zero layers).
          size: (width, height) in pixels.
          pixel_pos, pixel_radius: the units in this view's pixels.
          box: the `paint` window.
          xs, ys: world x of each column and y of each row.
          spacing: world units between adjacent pixel centres.
          extra_bits: name -> () -> int[H, W] for 0/1 layers specific to this view.
          previous: None, or int32[len(names), H, W]: these layers as this renderer drew
            them for an earlier state (of any episode).

        Returns:
          int32[len(names), H, W].
        """
        units = state.units
        n = units.num_slots
        unit_names = [name for name in names
                      if name in FIELD_BITS and name not in self.zero_layers]
        wants_density = any(name in DENSITY for name in names)
        # A paint key is the unit's rank + 1 above one of its packed words, so a pixel
        # keeps the top unit's word, and 0 where no unit is.
        word_bits = 31 - rank_bound(n).bit_length()
        packing = pack_fields(unit_names, word_bits)
        keys = self._unit_keys(units, state.researched, packing, word_bits)
        painted = keys if paints_every_word(n, box, size) else keys[:1]
        planes: dict[str, jnp.ndarray] = {}
        if unit_names or wants_density:
            words, density = paint(pixel_pos, pixel_radius, painted, self.units_shown(state),
                                   size, box, wants_density)
            if wants_density:
                planes["density"] = density
            if len(keys) > len(words):
                rank = words[0] >> word_bits
                top = jnp.where(rank > 0, rank_slot(rank - 1, n), n)
                words += [jnp.concatenate([key, jnp.zeros(1, jnp.int32)])[top]
                          for key in keys[len(words):]]
            planes.update({f"word{k}": word for k, word in enumerate(words)})
        terrain = self._terrain_plane(state, xs, ys, spacing, names, extra_bits)
        if terrain is not None:
            planes["terrain"] = terrain
        order = list(planes)
        source, shift, mask, multiplier, cap, kept = [], [], [], [], [], []
        static_view = isinstance(xs, np.ndarray) and isinstance(ys, np.ndarray)
        for name in names:
            if name in unit_names:
                word, bit, bits = packing[name]
                plane, scale, top_value = f"word{word}", 1, None
            elif name in DENSITY:
                plane, bit, bits = "density", 0, 31
                scale, top_value = DENSITY[name]
            elif (name in TERRAIN_PACKING and terrain is not None
                  and name not in self.zero_layers):
                plane, (bit, bits), scale, top_value = "terrain", TERRAIN_PACKING[name], 1, None
            else:  # A layer that is zero on these maps.
                plane, bit, bits, scale, top_value = None, 0, 0, 1, None
            kept.append(plane is None or (static_view and (
                name in STATIC_TERRAIN or (name == "visibility_map" and not self.fog))))
            source.append(order.index(plane) if plane is not None else 0)
            shift.append(bit)
            mask.append((1 << bits) - 1)
            multiplier.append(scale)
            cap.append(np.iinfo(np.int32).max if top_value is None else top_value)
        w, h = size
        column = lambda v: np.asarray(v, np.int32)[:, None, None]  # noqa: E731
        # Each plane is written once, and each layer picks its plane by a `where` chain:
        # a gather from the planes stacked on a layer axis makes XLA write the stack
        # and the layers with that axis first, and copy both to the batch-major layout.
        # (The density plane stays int16 until the cut reads it.)
        written = [materialize(planes[p]) for p in order]
        source = np.asarray(source)

        def cut(lo: int, hi: int):  # int32[hi - lo, H, W]: layers lo..hi-1.
            chosen = written[0][None].astype(jnp.int32)
            for k in range(1, len(order)):
                chosen = jnp.where(column(source[lo:hi] == k),
                                   written[k][None].astype(jnp.int32), chosen)
            layers = jnp.right_shift(chosen, column(shift[lo:hi])) & column(mask[lo:hi])
            if any(m != 1 for m in multiplier[lo:hi]):
                layers = jnp.minimum(layers * column(multiplier[lo:hi]), column(cap[lo:hi]))
            return layers

        if previous is not None:
            out = previous
            for lo, hi in _runs(np.logical_not(kept)):
                out = jax.lax.dynamic_update_slice(out, cut(lo, hi), (lo, 0, 0))
            return out
        if not order:
            return jnp.zeros((len(names), h, w), jnp.int32)
        return cut(0, len(names))

    def _unit_keys(self, units: Units, researched, packing: dict, word_bits: int) -> list:
        """Each unit's paint keys: its `draw_rank` + 1 above each of its packed words.

        Layers are bit-packed into a few words per unit (`pack_fields`), so `paint`
        draws the top unit's layer values directly: one scatter per word, and no
        per-pixel lookup of the top unit. Layers that are zero for every unit type of
        the map (energy and shields on these maps) take no bits.

        Returns:
          int32[N] keys, one per word.
        """
        per_unit = self._unit_values(units, researched)
        rank = jnp.left_shift(draw_rank(units) + 1, word_bits)
        keys = [rank] * (max((w for w, _, _ in packing.values()), default=-1) + 1)
        for name, (word, shift, bits) in packing.items():
            value = jnp.clip(per_unit[name](), 0, (1 << bits) - 1).astype(jnp.int32)
            keys[word] = keys[word] | jnp.left_shift(value, shift)
        return keys

    def screen(self, state: EnvState, previous=None):
        """int32[len(screen_layers), H, W]; `previous`: an earlier screen to write into
        (`_draw`)."""
        units = state.units
        camera = self.camera
        xs, ys = camera.pixel_centers(state.camera)
        radius = jnp.asarray(UNIT_DATA.radius)[units.type] * camera.pixels_per_unit
        return self._draw(state, [f.name for f in self.fmt.screen_layers], camera.size,
                          camera.world_to_pixel(state.camera, units.pos), radius,
                          self.screen_box, xs, ys, 1 / camera.pixels_per_unit, {}, previous)

    def minimap_layers(self, state: EnvState, previous=None):
        """int32[len(minimap_layers), H, W]; `previous`: an earlier minimap to write into
        (`_draw`)."""
        units = state.units
        minimap = self.minimap
        xs, ys = minimap.pixel_centers()
        radius = jnp.asarray(UNIT_DATA.radius)[units.type] * minimap.pixels_per_unit
        names = [f.name for f in self.fmt.minimap_layers]
        if not self.cheat_layers:  # PySC2 fills the minimap unit_type only when cheating.
            names_drawn = ["_none" if name == "unit_type" else name for name in names]
        else:
            names_drawn = names
        extra = {"camera": lambda: self._camera_layer(state.camera, xs, ys)}
        return self._draw(state, names_drawn, minimap.size, minimap.world_to_pixel(units.pos),
                          radius, self.minimap_box, xs, ys, 1 / minimap.pixels_per_unit, extra,
                          previous)

    def _camera_layer(self, center, xs, ys):
        hx, hy = self.camera.view_half_extent()
        in_x = (xs >= center[0] - hx) & (xs < center[0] + hx)
        in_y = (ys > center[1] - hy) & (ys <= center[1] + hy)
        return (in_y[:, None] & in_x[None, :]).astype(jnp.int32)

    @staticmethod
    def _unit_values(units: Units, researched) -> dict[str, Callable[[], jnp.ndarray]]:
        """Lazily computed int32[N] per-unit values of the per-unit screen layers (the
        health ratio of the player's most health, with its research: bool[R]
        `researched`)."""
        d = UNIT_DATA
        t = units.type
        return {
            "player_id": lambda: units.owner,
            "player_relative": lambda: player_relative(units.owner),
            "unit_type": lambda: jnp.asarray(d.sc2_id)[t],
            "selected": lambda: units.selected.astype(jnp.int32),
            "unit_hit_points": lambda: jnp.ceil(units.health).astype(jnp.int32),
            "unit_hit_points_ratio": lambda: ratio_255(units.health,
                                                       research.max_health(units, researched)),
            "unit_energy": lambda: units.energy.astype(jnp.int32),
            "unit_energy_ratio": lambda: ratio_255(units.energy, jnp.asarray(d.max_energy)[t]),
            "unit_shields": lambda: units.shields.astype(jnp.int32),
            "unit_shields_ratio": lambda: ratio_255(units.shields, jnp.asarray(d.max_shields)[t]),
            # Unfinished structures' progress (0..255); 0 for complete units.
            "build_progress": lambda: jnp.where(
                units.complete, 0, ratio_255(units.progress, jnp.asarray(d.build_time)[t])),
        }
