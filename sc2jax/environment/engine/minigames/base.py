"""What a mini-game is to the engine, and helpers its scripts share.

A mini-game is the map's trigger script: `init` places the starting units, `on_loop`
runs after every game loop with that loop's events (rewards, wave resets, defeat), and
`on_step` after each agent step's last loop (costly respawns). The engine handles
everything else, including the timer.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine.rules.dynamics import LoopEvents
from sc2jax.environment.engine.rules.geometry import MapGeometry, squared_length
from sc2jax.environment.engine.rules.state import EnvState, Outcome, Units
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType

Rect = tuple[float, float, float, float]

MAP_SIZE = (64, 64)
CAMERA_BOUNDS = (10.0, 8.0, 54.0, 44.0)


def flat_geometry(playable: Rect, height: int = 0) -> MapGeometry:
    """A 64x64 map, flat, pathable and buildable inside the playable area."""
    w, h = MAP_SIZE
    x0, y0, x1, y1 = playable
    xs = np.arange(w) + 0.5
    ys = h - 1 - np.arange(h) + 0.5  # Row 0 is the top.
    inside = ((ys >= y0) & (ys < y1))[:, None] & ((xs >= x0) & (xs < x1))[None, :]
    return MapGeometry(size=MAP_SIZE, playable=playable, camera_bounds=CAMERA_BOUNDS,
                       height_map=np.full((h, w), height, np.uint8), pathable=inside,
                       buildable=inside.copy())


@dataclasses.dataclass(frozen=True, eq=False)
class MiniGame:
    """A mini-game: its static layout, and its script.

    Attributes:
      name: the map name.
      time_limit: the map's timer, in game seconds.
      num_slots: unit slots (the most units the map can hold at once).
      geometry: the map's static layout.
      fog: whether fog of war is on (else the playable area is revealed).
      camera: the camera centre the script pans to.
      unit_types: every `UnitType` the map can hold (sizes the renderer's windows).
      starting_minerals: the player's minerals at the start.
      has_enemies: whether the map has enemy units (else the engine skips combat).
      collider_slots: None where any slot can hold a unit that collides; else units that
        collide are only ever in the first `collider_slots` slots (the rest hold items
        such as shards), and the engine resolves collisions among those alone.
      own_slots: None where any slot can hold one of the player's units; else the
        player's units are only ever in the first `own_slots` slots, and fog of war
        looks through those alone.
      field_slots: None where any slot can hold a mineral field; else mineral fields are
        only ever in the first `field_slots` slots (none is ever created), and
        workers look for free fields among those alone.
      resource_slots: None, or R where the first R slots hold the map's mineral fields
        and geysers and nothing else (a resource's slot is never reused:
        `state.open_slots`); they never move or fight, and combat, collision pushes
        and workers' approach look at the other slots alone.
      team_split: None where any slot can hold a unit of either side; else one side's
        units are only ever in the first `team_split` slots and the other side's only
        in the rest, and combat looks at the pairs across the split alone.
      slot_sizes: None, or ascending sizes ending at `num_slots`, for a map whose
        units fill its slots from the front, leaving most of them empty for much of an
        episode: the engine runs an agent step's game loops on the leading slots in use
        and the room for the units the step can create, and renders the observation on
        the leading slots in use, each rounded up to one of these sizes (`Simulator`).
      spawn_room: the most units the script creates at once (a wave's reinforcements):
        room the engine leaves for them in the slots an agent step needs.
      players: 1, or 2 for a melee map: the other player (`Owner.ENEMY`) then has its
        own bank, research, score and view (`players.Side`).
      timer_outcome: the `Outcome` when the map's timer runs out.
    """

    name: str
    time_limit: int
    num_slots: int
    geometry: MapGeometry
    fog: bool
    camera: tuple[float, float]
    unit_types: tuple[UnitType, ...]
    starting_minerals: int = 0
    has_enemies: bool = True
    collider_slots: int | None = None
    own_slots: int | None = None
    field_slots: int | None = None
    resource_slots: int | None = None
    team_split: int | None = None
    slot_sizes: tuple[int, ...] | None = None
    spawn_room: int = 0
    players: int = 1
    timer_outcome: Outcome = Outcome.VICTORY

    def __post_init__(self):
        sizes = self.slot_sizes
        if sizes is None:
            return
        smallest = max(self.collider_slots or 0, self.own_slots or 0, self.field_slots or 0,
                       self.resource_slots or 0, self.team_split or 0)
        if list(sizes) != sorted(set(sizes)) or sizes[-1] != self.num_slots or (
                sizes[0] <= smallest):
            raise ValueError(f"{self.name}: slot_sizes must ascend from above {smallest} "
                             f"to num_slots ({self.num_slots}), got {sizes!r}")

    def init(self, key) -> tuple[Units, Any, jax.Array]:
        """Returns the starting units, the script's state, and the next unit tag."""
        raise NotImplementedError

    def start_cameras(self, map_state) -> np.ndarray:
        """float32[P, 2]: each player's camera centre at the start (the script's
        state from `init`: a melee map's start locations are drawn)."""
        del map_state
        return np.array([self.camera] * self.players, np.float32)

    def on_start(self, state: EnvState) -> EnvState:
        """Runs on the episode's first state, once it is made."""
        return state

    def on_loop(self, state: EnvState, events: LoopEvents) -> EnvState:
        """Runs the script after a game loop; returns the state with score and outcome."""
        raise NotImplementedError

    def on_step(self, state: EnvState) -> EnvState:
        """Runs after the agent step's last game loop: respawns that need many random
        draws happen here rather than in `on_loop`. This is observationally equivalent
        where the respawned units are placed out of reach of the player's units for the
        rest of the step (shards at least 2 away, zerglings at least 9), since the
        agent only observes at step boundaries."""
        return state

    @property
    def time_limit_loops(self) -> int:
        return self.time_limit * 16

    @property
    def zero_layers(self) -> tuple[str, ...]:
        """Per-unit layers that are zero for every unit type of the map."""
        out = []
        if all(UNIT_DATA.max_energy[t] == 0 for t in self.unit_types):
            out += ["unit_energy", "unit_energy_ratio"]
        if all(UNIT_DATA.max_shields[t] == 0 for t in self.unit_types):
            out += ["unit_shields", "unit_shields_ratio"]
        if not self.has_production:  # Nothing is ever under construction.
            out += ["build_progress"]
        return tuple(out)

    @property
    def has_bursts(self) -> bool:
        """Whether a unit type of the map has a suicide splash attack (the Baneling)."""
        return any(UNIT_DATA.burst[t] > 0 for t in self.unit_types)

    @property
    def has_air(self) -> bool:
        """Whether a unit type of the map flies (weapons then hit only what they target)."""
        return any(UNIT_DATA.flying[t] for t in self.unit_types)

    @property
    def has_workers(self) -> bool:
        """Whether the map has workers (SCVs), which harvest."""
        return UnitType.SCV in self.unit_types

    @property
    def has_production(self) -> bool:
        """Whether the map has producers and builders (a Command Center)."""
        return UnitType.COMMAND_CENTER in self.unit_types

    @property
    def max_radius(self) -> float:
        """The largest radius of the map's unit types, world units."""
        return float(max(UNIT_DATA.radius[t] for t in self.unit_types))


def uniform_in_rect(key, rect: Rect, shape=()):
    """float32[*shape, 2] uniform points in a rectangle (x0, y0, x1, y1)."""
    x0, y0, x1, y1 = rect
    return jax.random.uniform(key, shape + (2,), minval=jnp.array([x0, y0]),
                              maxval=jnp.array([x1, y1]))


def candidates(key, sample: Callable, tries: int):
    """float32[tries, 2]: the i.i.d. draws `first_valid` chooses from (`sample(k)` for
    each of `tries` keys split from `key`)."""
    return jax.vmap(sample)(jax.random.split(key, tries))


def pick_first_valid(points, ok):
    """float32[2]: the first of `points` (float32[tries, 2]) where `ok` (bool[tries]), or
    the last point if none is valid."""
    tries = ok.shape[0]
    return points[jnp.where(ok.any(), jnp.argmax(ok), tries - 1)]


def first_valid(key, sample: Callable, valid: Callable, tries: int = 32):
    """Rejection sampling with a fixed budget: the first of `tries` draws that is valid.

    The first valid draw of i.i.d. candidates follows exactly the distribution of a
    rejection-sampling loop; if none is valid (vanishingly rare for the budgets used),
    the last draw is returned.

    Args:
      key: RNG key.
      sample: key -> float32[2] point.
      valid: float32[tries, 2] -> bool[tries].
      tries: the budget.
    """
    points = candidates(key, sample, tries)
    return pick_first_valid(points, valid(points))


def nearest_distance(points, others, mask):
    """float32[...]: distance from each point (float32[..., 2]) to the nearest of the K
    `others` (float32[K, 2], K static and small) where `mask` (bool[K]); inf where none.

    A running minimum over the others, elementwise: XLA's CPU backend hands a minimum
    over a small trailing axis to a library reduction (about 2 us per environment step
    in FindAndDefeatZerglings' resets at 1,024 environments). The same values.
    """
    nearest = jnp.full(jnp.shape(points)[:-1], jnp.inf, jnp.float32)
    for k in range(others.shape[0]):
        distance = jnp.sqrt(squared_length(points - others[k]))
        nearest = jnp.minimum(nearest, jnp.where(mask[k], distance, jnp.inf))
    return nearest
