"""A person's view of the simulator: a top-down colour picture of one state (jittable).

`HumanView(sim, width)` draws a rectangle of the map (by default the playable area and a
margin; `region` picks another, e.g. the whole map for a minimap) at `width` pixels
across, the height following the rectangle's shape. From the bottom up:

- the terrain: pathable ground shaded by height, cliffs and unpathable cells dark, and
  everything outside the playable area dimmed;
- fog of war, on maps that have it: cells never seen nearly black, cells seen before
  half dark;
- the player's orders: a line from each of its units to the target of its current order
  (green to move or patrol, red to attack, blue to gather or return cargo, yellow to
  build);
- units, sized by their radius and coloured by owner (the player green, the enemy red),
  each with a darker rim: structures and mineral fields as their footprint's rectangle,
  mineral shards as small diamonds, beacons as rings, the rest as discs; a unit drawn
  over another follows the feature layers' order (`render.draw_rank`);
- a ring around each selected unit;
- bars above each unit with hit points: health (green on dark red), and shields (blue)
  and energy (violet) above it where the type has them;
- the camera's rectangle, in white.

Units are drawn where the observation's renderer shows them (`Renderer.units_shown`): the
enemy only in sight on fog maps. So the picture is what the agent saw, from the state
the observation is rendered from. `draw` takes one `EnvState` and returns uint8[H, W, 3];
vmap it over a batch or an episode's states.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.render import draw_rank, rank_bound, rank_slot, sight_grid
from sc2jax.environment.engine.rules.geometry import cell_lookup
from sc2jax.environment.engine.rules.state import (
    EnvState,
    Order,
    Owner,
    leading_slots,
    slots_in_use,
)
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.engine.xla.lazy import smallest_fit
from sc2jax.environment.interface.camera import CAMERA_WIDTH

MARGIN = 3.0
"""World units shown around the playable area by default."""

# Shapes.
DISC, BOX, DIAMOND, RING = 0, 1, 2, 3
_SHAPE = np.full(len(UnitType), DISC, np.int32)
_SHAPE[UNIT_DATA.footprint[:, 0] > 0] = BOX
_SHAPE[[UnitType.VESPENE_GEYSER]] = DISC
_SHAPE[[UnitType.MINERAL_SHARD]] = DIAMOND
_SHAPE[[UnitType.BEACON]] = RING

# Colours.
SELF_COLOUR = (40, 200, 60)
ENEMY_COLOUR = (220, 50, 40)
NEUTRAL_COLOUR = (170, 170, 170)
_TYPE_COLOUR = {UnitType.BEACON: (120, 240, 170), UnitType.MINERAL_SHARD: (90, 230, 250),
                UnitType.MINERAL_FIELD: (70, 140, 235), UnitType.VESPENE_GEYSER: (40, 160, 150)}
SELECTION_COLOUR = (140, 255, 140)
CAMERA_COLOUR = (255, 255, 255)
HEALTH_COLOUR, HEALTH_LOST_COLOUR = (70, 220, 70), (90, 20, 20)
SHIELDS_COLOUR, ENERGY_COLOUR = (70, 150, 255), (200, 90, 240)
_ORDER_COLOUR = np.zeros((len(Order), 3), np.float32)
for _orders, _rgb in (((Order.MOVE, Order.PATROL), (120, 230, 120)),
                      ((Order.ATTACK_MOVE, Order.ATTACK_UNIT), (240, 90, 70)),
                      ((Order.GATHER, Order.RETURN), (100, 190, 250)),
                      ((Order.BUILD, Order.CONSTRUCT), (240, 220, 90))):
    _ORDER_COLOUR[list(_orders)] = _rgb
_DRAWS_ORDER = _ORDER_COLOUR.any(axis=1)  # HOLD and NONE draw no line.
_OWNER_TABLE = np.tile(np.float32(NEUTRAL_COLOUR), (Owner.NEUTRAL + 1, 1))
_OWNER_TABLE[Owner.SELF], _OWNER_TABLE[Owner.ENEMY] = SELF_COLOUR, ENEMY_COLOUR
_TYPE_TABLE = np.zeros((len(UnitType), 3), np.float32)
_BY_TYPE = np.zeros(len(UnitType), bool)
for _type, _rgb in _TYPE_COLOUR.items():
    _TYPE_TABLE[_type], _BY_TYPE[_type] = _rgb, True


@dataclasses.dataclass(frozen=True, eq=False)
class HumanView:
    """Draws one map's states as a person sees them (a static config; `draw` is pure).

    Args:
      sim: the simulator whose states are drawn (its map, and its renderer's fog rules).
      width: the picture's width in pixels (8..4096).
      region: (x0, y0, x1, y1) in world units, the part of the map drawn; None for the
        playable area with `MARGIN` around it, clipped to the map.

    Raises:
      ValueError: for a bad width or region.
    """

    sim: Simulator
    width: int = 256
    region: tuple[float, float, float, float] | None = None

    def __post_init__(self):
        if isinstance(self.width, bool) or not isinstance(self.width, int) or not (
                8 <= self.width <= 4096):
            raise ValueError(f"width must be an int in [8, 4096], got {self.width!r}")
        geometry = self.sim.game.geometry
        w, h = geometry.size
        if self.region is None:
            x0, y0, x1, y1 = geometry.playable
            region = (max(x0 - MARGIN, 0.0), max(y0 - MARGIN, 0.0), min(x1 + MARGIN, w),
                      min(y1 + MARGIN, h))
        else:
            region = tuple(float(v) for v in self.region)
            if len(region) != 4 or not (region[0] < region[2] and region[1] < region[3]):
                raise ValueError(f"region must be (x0, y0, x1, y1) with x0 < x1 and y0 < y1, "
                                 f"got {self.region!r}")
        object.__setattr__(self, "region", region)
        scale = self.width / (region[2] - region[0])
        object.__setattr__(self, "scale", scale)
        object.__setattr__(self, "height", max(1, round((region[3] - region[1]) * scale)))
        object.__setattr__(self, "_terrain", self._draw_terrain())
        # The window drawn around each unit: its largest body, ring and three bars.
        bar_h = max(2.0, round(scale * 0.2))
        # A footprint's half is at most its type's radius; rings go 1.2 times out.
        reach = max(scale * 1.2 * self.sim.game.max_radius, 0.9)
        object.__setattr__(self, "bar_height", bar_h)
        object.__setattr__(self, "window", 2 * int(np.ceil(reach + 2.2 + 3 * (bar_h + 1))) + 3)

    @property
    def shape(self) -> tuple[int, int, int]:
        """(height, width, 3)."""
        return self.height, self.width, 3

    def pixel_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """(xs float32[W], ys float32[H]): the world point at each column's and row's
        centre (rows from the top)."""
        x0, _, _, y1 = self.region
        xs = x0 + (np.arange(self.width, dtype=np.float32) + 0.5) / self.scale
        ys = y1 - (np.arange(self.height, dtype=np.float32) + 0.5) / self.scale
        return xs.astype(np.float32), ys.astype(np.float32)

    def to_pixels(self, world):
        """float32[..., 2]: the picture's (column, row) coordinates of world points
        (float32[..., 2]); a pixel's centre is at its index + 0.5."""
        x0, _, _, y1 = self.region
        world = jnp.asarray(world, jnp.float32)
        return jnp.stack([(world[..., 0] - x0) * self.scale,
                          (y1 - world[..., 1]) * self.scale], axis=-1)

    def _draw_terrain(self) -> np.ndarray:
        """float32[H, W, 3]: the fixed ground (numpy, made once)."""
        geometry = self.sim.game.geometry
        xs, ys = self.pixel_centres()
        map_h = geometry.size[1]
        pathable = cell_lookup(geometry.pathable, map_h, xs, ys, False)
        height = cell_lookup(geometry.height_map, map_h, xs, ys, 0).astype(np.float32)
        ground = np.float32([78, 70, 56]) * (0.75 + 0.5 * height / 255.0)[..., None]
        out = np.where(pathable[..., None], ground, np.float32([30, 30, 36]))
        px0, py0, px1, py1 = geometry.playable
        in_play = ((xs >= px0) & (xs <= px1))[None, :] & ((ys >= py0) & (ys <= py1))[:, None]
        return np.where(in_play[..., None], out, out * 0.45).astype(np.float32)

    def draw(self, state: EnvState):
        """uint8[H, W, 3]: the picture of one state."""
        units = state.units
        xs, ys = self.pixel_centres()
        image = jnp.asarray(self._terrain)
        if self.sim.game.fog:
            seen = sight_grid(units, jnp.asarray(xs), jnp.asarray(ys), 1 / self.scale,
                              self.sim.game.own_slots)
            explored = cell_lookup(state.explored, self.sim.game.geometry.size[1],
                                   jnp.asarray(xs), jnp.asarray(ys), False)
            image = image * jnp.where(seen, 1.0, jnp.where(explored, 0.55, 0.2))[..., None]
        shown = self.sim.renderer.units_shown(state)
        key = self._marks(units, shown)
        image = self._colour(image, key, units)
        return jnp.clip(jnp.round(self._camera(image, state.camera)), 0, 255).astype(jnp.uint8)

    # Everything drawn for units is one scatter of marks, each an int32 key that orders
    # what is drawn over what: (layer << rank bits | unit rank) << 2 | detail. The highest
    # key at a pixel is drawn.

    def _marks(self, units, shown):
        """int32[H * W]: the highest mark at each pixel, -1 where none.

        On maps with slot sizes (as the observation's renderer), drawn from the leading
        slots in use only: the slots past the last living unit draw nothing.
        """
        bits = rank_bits(units.num_slots)

        def draw(size, operand):
            units, shown, rank = leading_slots(operand, size)
            centre = self.to_pixels(units.pos)  # [N, 2]
            radius, half, reach = self._sizes(units)
            marks = [self._order_marks(units, shown, centre), self._unit_marks(
                units, shown, centre, rank, radius, half, reach, bits)]
            index = jnp.concatenate([m[0].reshape(-1) for m in marks])
            keys = jnp.concatenate([m[1].reshape(-1) for m in marks])
            return jnp.full(self.height * self.width, -1, jnp.int32).at[index].max(
                keys, mode="drop")

        operand = (units, shown, draw_rank(units))
        sizes = self.sim.game.slot_sizes if self.sim.use_slot_sizes else None
        if sizes is None:
            return draw(units.num_slots, operand)
        return smallest_fit(slots_in_use(units.alive), sizes, draw, operand)

    def _sizes(self, units):
        """(radius, half footprint [N, 2], reach): pixels."""
        radius = jnp.maximum(jnp.asarray(UNIT_DATA.radius)[units.type] * self.scale, 0.75)
        half = jnp.asarray(UNIT_DATA.footprint, jnp.float32)[units.type] * 0.5 * self.scale
        return radius, half, jnp.maximum(radius, jnp.max(half, axis=-1) * 1.2)

    def _pixel_index(self, column, row):
        """int32: the flat pixel index of integer (column, row); out of the picture, an
        index the scatter drops."""
        inside = (column >= 0) & (column < self.width) & (row >= 0) & (row < self.height)
        return jnp.where(inside, row * self.width + column, self.height * self.width)

    def _order_marks(self, units, shown, centre):
        """Marks along a line from each of the player's units to its current order's
        target (layer 0)."""
        n = units.num_slots
        order = units.orders[:, 0]
        target_slot = units.order_unit[:, 0]
        target = jnp.where((target_slot >= 0)[:, None],
                           units.pos[jnp.clip(target_slot, 0, n - 1)], units.order_pos[:, 0])
        end = self.to_pixels(target)
        draws = shown & (units.owner == Owner.SELF) & jnp.asarray(_DRAWS_ORDER)[order]
        samples = 2 * int(np.ceil(np.hypot(self.width, self.height))) + 1
        t = jnp.linspace(0.0, 1.0, samples)[None, :, None]
        points = jnp.floor(centre[:, None, :] + t * (end - centre)[:, None, :]).astype(jnp.int32)
        index = self._pixel_index(points[..., 0], points[..., 1])
        index = jnp.where(draws[:, None], index, self.height * self.width)
        key = jnp.broadcast_to((jnp.arange(n, dtype=jnp.int32) << 2)[:, None], index.shape)
        return index, key

    def _unit_marks(self, units, shown, centre, rank, radius, half, reach, bits):
        """Marks of the bodies (layer 1; detail 1 on the rim), selection rings (layer 2)
        and vital bars (layer 3; detail: 0 lost, 1 health, 2 shields, 3 energy), in a
        window around each unit; `bits` are the rank's (of all the slots)."""
        bar_h = self.bar_height
        half_window = self.window // 2
        k = jnp.arange(self.window, dtype=jnp.int32) - half_window
        base = jnp.floor(centre).astype(jnp.int32)
        column = base[:, 0, None, None] + k[None, None, :]  # [N, 1, S]
        row = base[:, 1, None, None] + k[None, :, None]  # [N, S, 1]
        dx = column.astype(jnp.float32) + 0.5 - centre[:, 0, None, None]
        dy = row.astype(jnp.float32) + 0.5 - centre[:, 1, None, None]
        r, hw, hh = radius[:, None, None], half[:, 0, None, None], half[:, 1, None, None]
        adx, ady, d2 = jnp.abs(dx), jnp.abs(dy), dx * dx + dy * dy
        shape = jnp.asarray(_SHAPE)[units.type][:, None, None]
        body = jnp.select([shape == BOX, shape == DIAMOND, shape == RING],
                          [(adx <= hw) & (ady <= hh), adx + ady <= r * 1.3,
                           (d2 <= r * r) & (d2 >= (0.6 * r) ** 2)], d2 <= r * r)
        inner_r = jnp.maximum(r - 1.0, 0.0)
        inner = jnp.select(
            [shape == BOX, shape == DIAMOND, shape == RING],
            [(adx <= hw - 1.0) & (ady <= hh - 1.0), adx + ady <= r * 1.3 - 1.0,
             (d2 <= inner_r * inner_r) & (d2 >= (0.6 * r + 1.0) ** 2)],
            d2 <= inner_r * inner_r)
        rr = reach[:, None, None]
        ring = (d2 >= (rr + 1.0) ** 2) & (d2 <= (rr + 2.2) ** 2) & units.selected[:, None, None]
        # Bars: health at the bottom, then shields and energy where the type has them.
        bar_w = jnp.maximum(2.0 * rr, 6.0)
        in_x = adx <= bar_w / 2
        bottom = -rr - 1.0
        bar = jnp.full(dx.shape, -1, jnp.int32)
        for detail, (value, maximum) in enumerate(
                ((units.health, UNIT_DATA.max_health), (units.shields, UNIT_DATA.max_shields),
                 (units.energy, UNIT_DATA.max_energy)), start=1):
            maximum = jnp.asarray(maximum)[units.type][:, None, None]
            has = maximum > 0
            here = in_x & (dy >= bottom - bar_h) & (dy < bottom) & has
            fraction = jnp.clip(value[:, None, None] / jnp.maximum(maximum, 1.0), 0.0, 1.0)
            full = dx + bar_w / 2 <= bar_w * fraction
            bar = jnp.where(here, jnp.where(full, detail, 0), bar)
            bottom = jnp.where(has, bottom - bar_h - 1.0, bottom)
        r3 = rank[:, None, None]
        key = jnp.select(
            [bar >= 0, ring, body],
            [(((3 << bits) | r3) << 2) | bar, ((2 << bits) | r3) << 2,
             (((1 << bits) | r3) << 2) | (~inner).astype(jnp.int32)], -1)
        index = jnp.where(shown[:, None, None] & (key >= 0), self._pixel_index(column, row),
                          self.height * self.width)
        return jnp.broadcast_to(index, key.shape), key

    def _colour(self, image, key, units):
        """float32[H, W, 3]: the image with each pixel's highest mark drawn."""
        bits = rank_bits(units.num_slots)
        key = key.reshape(self.height, self.width)
        detail = key & 3
        layer = key >> (2 + bits)
        slot = rank_slot(jnp.maximum(key, 0) >> 2, units.num_slots)
        order = units.orders[:, 0][slot]
        body = _unit_colours(units)[slot]
        bar = jnp.asarray(np.float32([HEALTH_LOST_COLOUR, HEALTH_COLOUR, SHIELDS_COLOUR,
                                      ENERGY_COLOUR]))[detail]
        colour = jnp.select(
            [layer[..., None] == 0, layer[..., None] == 1, layer[..., None] == 2],
            [jnp.asarray(_ORDER_COLOUR)[order],
             jnp.where(detail[..., None] == 1, body * 0.6, body),
             jnp.broadcast_to(jnp.asarray(SELECTION_COLOUR, jnp.float32), body.shape)], bar)
        return jnp.where((key >= 0)[..., None], colour, image)

    def _camera(self, image, camera):
        """The camera's rectangle drawn over the image (float32[H, W, 3])."""
        px = jnp.arange(self.width, dtype=jnp.float32) + 0.5
        py = jnp.arange(self.height, dtype=jnp.float32) + 0.5
        half = jnp.asarray([CAMERA_WIDTH / 2, CAMERA_WIDTH / 2 * _screen_aspect(self.sim)])
        corners = self.to_pixels(jnp.stack([camera - half, camera + half]))
        left, right = corners[0, 0], corners[1, 0]
        top, bottom = corners[1, 1], corners[0, 1]

        def box(pad):
            return ((px[None, :] >= left + pad) & (px[None, :] <= right - pad)
                    & (py[:, None] >= top + pad) & (py[:, None] <= bottom - pad))

        edge = box(-0.5) & ~box(0.5)
        return jnp.where(edge[..., None], jnp.asarray(CAMERA_COLOUR, jnp.float32), image)


def rank_bits(num_slots: int) -> int:
    """The bits of a `render.draw_rank` of this many slots."""
    return max(rank_bound(num_slots) - 1, 1).bit_length()


def _screen_aspect(sim: Simulator) -> float:
    """The screen's height over its width (the camera's rectangle has its shape)."""
    w, h = sim.fmt.screen_size
    return h / w


def _unit_colours(units) -> jnp.ndarray:
    """float32[N, 3]: each unit's body colour, by type for resources and beacons, else by
    owner."""
    return jnp.where(jnp.asarray(_BY_TYPE)[units.type][:, None],
                     jnp.asarray(_TYPE_TABLE)[units.type],
                     jnp.asarray(_OWNER_TABLE)[jnp.clip(units.owner, 0, Owner.NEUTRAL)])
