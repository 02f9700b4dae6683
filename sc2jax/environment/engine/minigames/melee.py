"""Melee maps: a Terran-versus-Terran 1v1 on a ladder map's layout (`ladder`).

The layout re-created from professional replays gives the map's size, the start
locations, and every mineral field and geyser at its exact position. Each player starts
as in a melee game: a Command Center at its start location, 12 SCVs around it mining
(the game sends them to the minerals at the start), and 50 minerals; which start
location is whose is drawn each episode. The other player is `Owner.ENEMY`, with its
own bank, research, score and view (`players`). A player whose structures are all
destroyed (flying ones count) loses, and both at once tie; the map's timer, 30 minutes
of game time (PySC2's `game_steps_per_episode` for ladder maps, 28,800 game loops),
ends the game in a tie. Fog of war is on. `score` (`score_cumulative[0]`) is each
player's Blizzard score (`score.blizzard_score`), as the game's.

Terrain, which no replay holds (docs/fidelity.md): the map is flat; units move over open
ground inside the playable area (the box around every cell a ground unit was seen on);
structures are placed on the cells seen, with holes of a cell or two closed. Mineral
fields hold 1,800 minerals (900 for the `*750` kinds) and geysers 2,250 vespene; all
show as the plain Mineral Field and Vespene Geyser. Rocks and towers are left out.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine import ladder
from sc2jax.environment.engine.minigames.base import MiniGame
from sc2jax.environment.engine.rules import players, production, score
from sc2jax.environment.engine.rules.geometry import MapGeometry
from sc2jax.environment.engine.rules.state import EnvState, Order, Outcome, Owner, Units, place
from sc2jax.environment.engine.rules.units import UNIT_DATA, Attribute, UnitType, terran_types
from sc2jax.environment.interface.map_names import LADDER_MAPS

STARTING_MINERALS = 50
STARTING_SCVS = 12
TIME_LIMIT = 30 * 60
"""The map's timer, game seconds: PySC2's ladder maps' 30 minutes (28,800 game loops)."""
FIELDS_A_BASE = 8
"""The mineral fields of a start location, which its starting SCVs share."""
SCV_RING = 3.5
"""The distance of the starting SCVs from their Command Center's centre."""
SMALL_FIELD = 900
"""The minerals of a `*MineralField750` (the larger kinds hold `UNIT_DATA.contents`)."""
NUM_SLOTS = 768
"""Room for two players at 200 supply with their structures, and the resources."""
SLOT_SIZES = (256, 512, NUM_SLOTS)

_STRUCTURE = (UNIT_DATA.attributes & Attribute.STRUCTURE) > 0


def pysc2_name(layout_name: str) -> str:
    """PySC2's name of a ladder map from its Battle.net name: "King's Cove LE" ->
    "KingsCove" (`pysc2.maps.ladder`'s rule)."""
    return re.sub(r"[ '-]|[LTRS]E$", "", layout_name)


LAYOUT_OF = {pysc2_name(name): name for name in ladder.layouts()}
"""PySC2 map name -> the packaged layout's name."""
assert tuple(sorted(LAYOUT_OF)) == tuple(sorted(LADDER_MAPS)), sorted(LAYOUT_OF)


def close_holes(cells: np.ndarray, radius: int = 1) -> np.ndarray:
    """bool[H, W]: `cells` dilated then eroded by a (2 radius + 1)² square: gaps of up
    to 2 radius cells between cells are filled; the outline stays."""
    def sweep(grid, combine):
        out = grid.copy()
        for dy in range(-radius, radius + 1):
            for dx in range(-radius, radius + 1):
                shifted = np.roll(np.roll(grid, dy, axis=0), dx, axis=1)
                out = combine(out, shifted)
        return out

    padded = np.pad(cells, radius + 1)
    closed = sweep(sweep(padded, np.logical_or), np.logical_and)
    return closed[radius + 1:-radius - 1, radius + 1:-radius - 1]


BASE_LINK = 9.0
"""World units within which resources belong to one base (single linkage): a base's
mineral fields and geysers lie within a few units of each other, bases 20 or more
apart."""
BASE_REACH = 14
"""Cells from a base's resources' centre that `base_sites` looks for its site within."""


def resource_groups(points: np.ndarray, link: float = BASE_LINK) -> np.ndarray:
    """int32[M]: each resource's base (points float32[M, 2]): the groups linked by
    distances of at most `link`, numbered by their first resource."""
    label = np.full(len(points), -1, np.int32)
    for seed in range(len(points)):
        if label[seed] >= 0:
            continue
        label[seed], stack = label.max() + 1, [seed]
        while stack:
            near = np.linalg.norm(points - points[stack.pop()], axis=1) <= link
            fresh = np.flatnonzero(near & (label < 0))
            label[fresh] = label[seed]
            stack.extend(fresh)
    return label


def base_sites(layout: ladder.MapLayout, buildable: np.ndarray) -> np.ndarray:
    """float32[B, 2]: where each base's Command Center goes, as the game places a town
    hall: of the sites whose 5 x 5 footprint lies on buildable cells (bool[H, W], rows
    top first) and keeps its clearance from every resource
    (`production.near_resources`), the one nearest its resources in summed distance.
    Bases with no buildable site (where the replays never showed the ground) are left
    out. The start locations are among the sites, exactly (`tests`)."""
    fields = np.array([m[:2] for m in layout.minerals], np.float32)
    geysers = np.array([g[:2] for g in layout.geysers], np.float32)
    points = np.concatenate([fields, geysers])
    sizes = np.concatenate([np.broadcast_to(UNIT_DATA.footprint[t], (len(p), 2)) for t, p in (
        (UnitType.MINERAL_FIELD, fields), (UnitType.VESPENE_GEYSER, geysers))]).astype(np.float32)
    cc = UNIT_DATA.footprint[UnitType.COMMAND_CENTER].astype(np.float32)
    (w, h), (fw, fh) = buildable.shape[::-1], cc.astype(int)
    span = np.arange(-BASE_REACH, BASE_REACH + 1, dtype=np.float32)
    groups, sites = resource_groups(points), []
    for group in range(groups.max() + 1):
        members = points[groups == group]
        centre = np.floor(members.mean(0)) + 0.5
        grid = np.stack(np.meshgrid(span, span), -1).reshape(-1, 2) + centre
        with jax.ensure_compile_time_eval():  # Static, also where first asked in a trace.
            clear = ~np.asarray(jax.vmap(lambda site: jnp.any(production.near_resources(
                site, cc, points, sizes)))(grid))
        corner = np.floor(grid - cc / 2).astype(int)  # The footprint's lowest cell.
        inside = np.all((corner >= 0) & (corner + (fw, fh) <= (w, h)), 1)
        on_ground = np.array([ok and buildable[h - y - fh:h - y, x:x + fw].all()
                              for (x, y), ok in zip(corner, inside)])
        cost = np.linalg.norm(grid[:, None] - members[None], axis=-1).sum(1)
        cost = np.where(clear & on_ground, cost, np.inf)
        if np.isfinite(cost).any():
            sites.append(grid[np.argmin(cost)])
    return np.array(sites, np.float32)


def melee_geometry(layout: ladder.MapLayout) -> MapGeometry:
    """The map's static layout: flat; pathable over the playable box; buildable on the
    ground seen, holes closed (rows top first, as `MapGeometry`)."""
    w, h = layout.map_size
    x0, y0, x1, y1 = layout.playable
    box = np.zeros((h, w), bool)
    box[y0:y1, x0:x1] = True
    buildable = close_holes(layout.ground) & box
    return MapGeometry(size=(w, h), playable=(float(x0), float(y0), float(x1), float(y1)),
                       camera_bounds=(float(x0), float(y0), float(x1), float(y1)),
                       height_map=np.zeros((h, w), np.uint8), pathable=box[::-1].copy(),
                       buildable=buildable[::-1].copy())


@dataclasses.dataclass(frozen=True, eq=False)
class Melee(MiniGame):
    """A two-player melee game on a ladder map's layout (`Melee.on(name)`).

    Attributes:
      layout: the map's layout.
    """

    layout: ladder.MapLayout | None = None

    @classmethod
    def on(cls, name: str) -> Melee:
        """The melee game of ladder map `name` (one of `LADDER_MAPS`)."""
        layout = ladder.load_layout(LAYOUT_OF[name])
        types = (UnitType.MINERAL_FIELD, UnitType.VESPENE_GEYSER,
                 *sorted(terran_types().values()))
        return cls(name=name, time_limit=TIME_LIMIT, num_slots=NUM_SLOTS,
                   geometry=melee_geometry(layout), fog=True,
                   camera=tuple(layout.start_locations[0]), unit_types=types,
                   starting_minerals=STARTING_MINERALS, field_slots=len(layout.minerals),
                   resource_slots=len(layout.minerals) + len(layout.geysers),
                   slot_sizes=SLOT_SIZES, players=2, timer_outcome=Outcome.TIE,
                   layout=layout)

    @property
    def start_units(self) -> int:
        """The units alive at the start: the resources and both players' bases."""
        return len(self.layout.minerals) + len(self.layout.geysers) + 2 * (1 + STARTING_SCVS)

    def _resources(self):
        fields = np.array([m[:2] for m in self.layout.minerals], np.float32)
        small = np.array(["750" in m[2] for m in self.layout.minerals])
        geysers = np.array([g[:2] for g in self.layout.geysers], np.float32)
        return fields, small, geysers

    def init(self, key):
        """Resources in the first slots (mineral fields, then geysers), then each
        player's Command Center and SCVs, the player's first. The script's state is
        int32 the player's start location (0 or 1; the other player's is the other)."""
        fields, small, geysers = self._resources()
        field_pos = jnp.asarray(fields)
        units = Units.empty(self.num_slots)
        units, tag = place(units, np.arange(len(fields)), UnitType.MINERAL_FIELD,
                           Owner.NEUTRAL, jnp.asarray(fields), 0)
        units = units.replace(contents=units.contents.at[np.flatnonzero(small)].set(
            float(SMALL_FIELD)))
        units, tag = place(units, len(fields) + np.arange(len(geysers)),
                           UnitType.VESPENE_GEYSER, Owner.NEUTRAL, jnp.asarray(geysers), tag)
        start = jax.random.bernoulli(key).astype(jnp.int32)
        starts = jnp.asarray(self.layout.start_locations, jnp.float32)
        angles = 2 * math.pi * np.arange(STARTING_SCVS) / STARTING_SCVS
        ring = SCV_RING * np.stack([np.cos(angles), np.sin(angles)], -1).astype(np.float32)
        slot = len(fields) + len(geysers)
        for owner, location in ((Owner.SELF, start), (Owner.ENEMY, 1 - start)):
            cc = starts[location]
            units, tag = place(units, np.array([slot]), UnitType.COMMAND_CENTER, owner,
                               cc[None], tag)
            scvs = slot + 1 + np.arange(STARTING_SCVS)
            units, tag = place(units, scvs, UnitType.SCV, owner, cc + ring, tag)
            # Each SCV gathers: the k-th from the (k mod 8)-th field nearest home.
            nearest = jnp.argsort(jnp.sum((field_pos - cc) ** 2, axis=-1))[:FIELDS_A_BASE]
            field = nearest[np.arange(STARTING_SCVS) % FIELDS_A_BASE].astype(jnp.int32)
            units = units.replace(orders=units.orders.at[scvs, 0].set(Order.GATHER),
                                  order_unit=units.order_unit.at[scvs, 0].set(field),
                                  order_pos=units.order_pos.at[scvs, 0].set(field_pos[field]))
            slot += 1 + STARTING_SCVS
        return units, start, tag

    @functools.cached_property
    def bases(self) -> np.ndarray:
        """float32[B, 2]: every base's Command Center site (`base_sites`)."""
        return base_sites(self.layout, self.geometry.buildable)

    def naturals(self, map_state) -> jax.Array:
        """float32[2, 2]: each player's natural expansion, the base nearest its start
        location (as `start_cameras`)."""
        starts = np.asarray(self.layout.start_locations, np.float32)
        away = np.linalg.norm(self.bases[None] - starts[:, None], axis=-1)
        natural = jnp.asarray(self.bases[np.argmin(np.where(away > 1.0, away, np.inf), 1)])
        return jnp.stack([natural[map_state], natural[1 - map_state]])

    def start_cameras(self, map_state) -> jax.Array:
        """float32[2, 2]: each player's camera on its start location."""
        starts = jnp.asarray(self.layout.start_locations, jnp.float32)
        return jnp.stack([starts[map_state], starts[1 - map_state]])

    def on_loop(self, state: EnvState, events) -> EnvState:
        """A player without structures loses (both at once: a tie)."""
        units = state.units
        standing = units.alive & jnp.asarray(_STRUCTURE)[units.type]
        own = jnp.any(standing & (units.owner == Owner.SELF))
        enemy = jnp.any(standing & (units.owner == Owner.ENEMY))
        outcome = jnp.where(own, jnp.where(enemy, int(Outcome.RUNNING), int(Outcome.VICTORY)),
                            jnp.where(enemy, int(Outcome.DEFEAT), int(Outcome.TIE)))
        return state.replace(outcome=jnp.where(state.outcome == Outcome.RUNNING, outcome,
                                               state.outcome).astype(jnp.int32))

    def on_start(self, state: EnvState) -> EnvState:
        return self.on_step(state)

    def on_step(self, state: EnvState) -> EnvState:
        """Each player's `score` is its Blizzard score."""
        seen = players.mirror(state)
        other = state.other.replace(score=score.blizzard_score(seen))
        return state.replace(score=score.blizzard_score(state), other=other)


def with_slots(game: MiniGame, num_slots: int) -> Melee:
    """A melee game with `num_slots` unit slots (`Simulator.num_slots`), its slot sizes
    those of `SLOT_SIZES` below it, then `num_slots`.

    Raises:
      ValueError: `game` is not a melee game, or `num_slots` is not an int from its
        starting units to 4,096.
    """
    if not isinstance(game, Melee):
        raise ValueError(f"num_slots applies to melee maps; {game.name} is a mini-game "
                         "with slots of its own")
    if isinstance(num_slots, bool) or not isinstance(num_slots, int) or not (
            game.start_units < num_slots <= 4096):
        raise ValueError(f"num_slots must be an int in [{game.start_units + 1}, 4096] on "
                         f"{game.name} (its starting units and room), got {num_slots!r}")
    sizes = tuple(size for size in SLOT_SIZES if size < num_slots) + (num_slots,)
    return dataclasses.replace(game, num_slots=num_slots, slot_sizes=sizes)
