"""The simulator: pure, jittable `reset` and `step` for one mini-game.

    sim = Simulator("MoveToBeacon")
    state, timestep = sim.reset(jax.random.PRNGKey(0))
    state, timestep = sim.step(state, dense_action)

`step` applies the action, runs `step_mul` game loops in `lax.scan` (16 loops per game
second), and observes. A step from a state whose last timestep was LAST starts a new
episode instead and returns FIRST, as dm_env (and PySC2) do. Batch with `jax.vmap`.
"""

from __future__ import annotations

import dataclasses
import functools

import dm_env
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from sc2jax.environment.engine import computer
from sc2jax.environment.engine.actions import apply_action, apply_raw
from sc2jax.environment.engine.availability import CARD_TABLE
from sc2jax.environment.engine.minigames import get_map, melee
from sc2jax.environment.engine.observation import observe
from sc2jax.environment.engine.raw_actions import apply_raw_action
from sc2jax.environment.engine.render import Renderer, sight_grid
from sc2jax.environment.engine.rules import (
    calldown,
    liftoff,
    players,
    production,
    research,
    score,
)
from sc2jax.environment.engine.rules.dynamics import facing_of, game_loop, turned
from sc2jax.environment.engine.rules.state import (
    NUM_SCORE_CUMULATIVE,
    EnvState,
    Outcome,
    leading_slots,
    slots_in_use,
)
from sc2jax.environment.engine.xla import threefry
from sc2jax.environment.engine.xla.fusion import set_static
from sc2jax.environment.engine.xla.lazy import lazy_where, smallest_fit
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.dense import DenseAction, check_dense_action
from sc2jax.environment.interface.raw import RawAction, raw_action_spec

BLIZZARD_SCORE = -2
"""`Simulator.score_index` for rewards from the Blizzard score."""


def check_score_index(score_index) -> None:
    """Raises ValueError unless `score_index` is one `Simulator` takes."""
    if isinstance(score_index, bool) or not isinstance(score_index, int) or not (
            BLIZZARD_SCORE <= score_index < NUM_SCORE_CUMULATIVE):
        raise ValueError(f"score_index must be -2 (the Blizzard score), -1 (win/loss) or "
                         f"in [0, {NUM_SCORE_CUMULATIVE - 1}], got {score_index!r}")


@struct.dataclass
class EnvParams:
    """Per-environment parameters (vmappable).

    Attributes:
      game_steps_per_episode: PySC2's episode limit in game loops; reaching it truncates
        the episode (LAST with the discount kept). 0 means no limit (the mini-games'
        default: their own timers end them).
    """

    game_steps_per_episode: jax.Array = dataclasses.field(
        default_factory=lambda: jnp.int32(0))


@dataclasses.dataclass(frozen=True, eq=False)
class Simulator:
    """One mini-game with a fixed observation format (a static, hashable config).

    Attributes:
      map_name: a mini-game (`minigames.MAPS`) or a ladder map (`map_names.LADDER_MAPS`).
      fmt: the observation format.
      step_mul: game loops per agent step.
      score_index: the reward: the change of `score_cumulative[score_index]` (0 is the
        mini-game score); `BLIZZARD_SCORE` (-2) for the change of the Blizzard score
        (`score.blizzard_score`); or -1 for the outcome (+1 victory, -1 defeat, 0 tie)
        at the end.
      score_multiplier: multiplies every reward.
      discount: the discount of MID steps (and of truncated LAST steps).
      allow_cheating_layers: fill the minimap `unit_type` layer.
      use_slot_sizes: on maps with `slot_sizes` (the economy, wave and melee maps), run
        the game loops and render the observation on the leading unit slots in use (the
        default); False runs them on every slot, with the same results, slower (for
        checks).
      computer: on a melee map, 0 (the other player does nothing, unless given actions:
        `step_both`) or the `Difficulty` the simulator's built-in AI plays the other
        player at (`computer.LEVELS`).
      num_slots: None, or on a melee map its unit slots in place of `melee.NUM_SLOTS`
        (768: two players at 200 supply): fewer cap the units the game holds (a unit
        trained without a free slot waits in its queue, a structure is not placed) and
        compile and run faster, for the early game.
    """

    map_name: str = "MoveToBeacon"
    fmt: specs.ObservationFormat = specs.ObservationFormat()
    step_mul: int = 8
    score_index: int = 0
    score_multiplier: float = 1.0
    discount: float = 1.0
    allow_cheating_layers: bool = False
    use_slot_sizes: bool = True
    num_slots: int | None = None
    computer: int = 0

    def __post_init__(self):
        game = get_map(self.map_name)
        if self.num_slots is not None:
            game = melee.with_slots(game, self.num_slots)
        if self.computer:
            if game.players != 2:
                raise ValueError(f"computer plays the other player of a melee map; "
                                 f"{self.map_name} has one player")
            object.__setattr__(self, "computer_level", computer.level(self.computer))
        if not isinstance(self.fmt, specs.ObservationFormat):
            raise ValueError(f"fmt must be an ObservationFormat, got {type(self.fmt).__name__}")
        if isinstance(self.step_mul, bool) or not isinstance(self.step_mul, int) or not (
                1 <= self.step_mul <= 10_000):
            raise ValueError(f"step_mul must be an int in [1, 10000], got {self.step_mul!r}")
        check_score_index(self.score_index)
        if not isinstance(self.use_slot_sizes, bool):
            raise ValueError(f"use_slot_sizes must be a bool, got {self.use_slot_sizes!r}")
        if not 0.0 <= self.discount <= 1.0:
            raise ValueError(f"discount must be in [0, 1], got {self.discount!r}")
        object.__setattr__(self, "game", game)
        object.__setattr__(self, "renderer", Renderer(
            self.fmt, game.geometry, game.fog, game.max_radius, game.zero_layers,
            self.allow_cheating_layers, game.own_slots))

    # Specs.

    def observation_spec(self) -> dict:
        return specs.observation_spec(self.fmt, padded=True)

    def action_spec(self) -> DenseAction | RawAction:
        """The spec of one action: a `DenseAction`'s, or with `fmt.action_space` "raw" a
        `RawAction`'s."""
        if self.fmt.action_space == "raw":
            return raw_action_spec(self.fmt.max_units, self.renderer.raw_grid.size)
        return specs.action_spec(self.fmt.screen_size, self.fmt.minimap_size)

    @property
    def card_table(self) -> np.ndarray:
        return getattr(self.game, "card_table", CARD_TABLE)

    # The functional API.

    def default_params(self) -> EnvParams:
        return EnvParams()

    def reset(self, key, params: EnvParams | None = None):
        """Starts an episode. Returns (state, TimeStep) with step_type FIRST."""
        del params
        state = self._initial_state(key)
        return state, self._timestep(state, jnp.int32(dm_env.StepType.FIRST), jnp.float32(0.0),
                                     jnp.float32(0.0))

    def reset_both(self, key, params: EnvParams | None = None):
        """Starts an episode of a two-player map. Returns (state, (the player's TimeStep,
        the other player's)), both FIRST, each with its own observation (`step_both`).

        Raises:
          ValueError: on a one-player map.
        """
        self._check_two_players("reset_both")
        state, timestep = self.reset(key, params)
        return state, (timestep, timestep._replace(
            observation=self._observe(players.mirror(state), None)))

    def step(self, state: EnvState, action: DenseAction | RawAction,
             params: EnvParams | None = None, previous: dict | None = None, loops=None,
             other_action: DenseAction | RawAction | None = None):
        """Advances one agent step (or starts a new episode after LAST).

        Args:
          state: the current state.
          action: an unbatched `DenseAction` (a `RawAction` with `fmt.action_space`
            "raw": `act`).
          params: the episode parameters.
          previous: None, or an observation this simulator returned before (the last
            timestep's, of any episode). The new observation's feature layers are
            written into its buffers, and the layers that are the same in every
            observation of this map and format (zero layers; the minimap's terrain, and
            its visibility on maps without fog) are kept, not written again: in a jitted
            loop that carries the timestep, XLA then updates them in place. The
            observation is the same as without it.
          loops: None to run `step_mul` game loops, or an int32 scalar in
            [1, 10000]: the step's game loops as a run-time value, so one compiled
            program runs any count (the SC2-API server's `RequestStep.count`). The
            step is then the step of a simulator with `step_mul=loops`, bit for bit.
          other_action: on a two-player map, None (the other player does nothing) or
            the other player's action, taken from its own observation
            (`step_both`), applied after the player's.

        Returns:
          (state, dm_env.TimeStep of arrays).

        Raises:
          ValueError: (while tracing) `previous`'s feature layers are not of this
            simulator's shapes, or `other_action` is given on a one-player map.
        """
        new, (timestep, _) = self._step(state, action, params, previous, loops, other_action,
                                        both=False)
        return new, timestep

    def step_both(self, state: EnvState, actions, params: EnvParams | None = None):
        """Both players of a two-player map act, each from its own observation, and the
        game advances one agent step (or starts a new episode after LAST), as PySC2's
        two-agent environments do.

        Args:
          state: the current state (the player's view; `players.mirror` is the other's).
          actions: (the player's `DenseAction`, the other player's).
          params: the episode parameters.

        Returns:
          (state, (the player's TimeStep, the other player's TimeStep)): the same step
          type and discount, each player's own reward and observation.

        Raises:
          ValueError: (while tracing) on a one-player map.
        """
        self._check_two_players("step_both")
        action, other_action = actions
        return self._step(state, action, params, None, None, other_action, both=True)

    def _check_two_players(self, what: str):
        if self.game.players != 2:
            raise ValueError(f"{what} needs a two-player map; {self.map_name} has one player")

    def _step(self, state, action, params, previous, loops, other_action, both: bool):
        """`step`, and the other player's timestep where `both`."""
        self._check_previous(previous)
        if other_action is not None and self.game.players != 2:
            raise ValueError(f"other_action applies to two-player maps; {self.map_name} has "
                             "one player")
        params = self.default_params() if params is None else params
        over = self.episode_over(state, params)
        reset_key, _ = threefry.split(state.key)
        # The auto-reset: a fresh episode, computed only when one starts.
        new = lazy_where(over, self._initial_state, reset_key,
                         self.advance(state, action, loops, other_action))
        ended = self.episode_over(new, params)
        terminated = new.outcome != Outcome.RUNNING
        step_type = jnp.where(over, dm_env.StepType.FIRST,
                              jnp.where(ended, dm_env.StepType.LAST, dm_env.StepType.MID))
        step_type = step_type.astype(jnp.int32)
        discount = jnp.where(over | terminated, 0.0, self.discount).astype(jnp.float32)

        def timestep(old, new, previous):
            reward = jnp.where(over, 0.0, self._reward(old, new, ended)) * self.score_multiplier
            return self._timestep(new, step_type, reward.astype(jnp.float32), discount,
                                  previous)

        other = (timestep(players.mirror(state), players.mirror(new), None) if both
                 else None)
        return new, (timestep(state, new, previous), other)

    def act(self, state: EnvState, action: DenseAction | RawAction) -> EnvState:
        """Applies an action without advancing the game (the SC2 API's `RequestAction`):
        a `DenseAction`, or with `fmt.action_space` "raw" a `RawAction`
        (`raw_actions`).

        Raises:
          ValueError: (while tracing, before any compilation) if `action` is not one
            environment's action of this simulator's action space (vmap `step` for a
            batch).
        """
        raw = self.fmt.action_space == "raw"
        expected = RawAction if raw else DenseAction
        if not isinstance(action, expected):
            raise ValueError(f"this simulator's action space is {self.fmt.action_space!r}: "
                             f"it takes a {expected.__name__}, got {type(action).__name__}")
        if raw:
            shape = jnp.shape(action.units)
            if jnp.shape(action.function) != () or shape != (self.fmt.max_units,):
                raise ValueError(f"a RawAction of one environment has function shape () "
                                 f"and units shape ({self.fmt.max_units},) (max_units), got "
                                 f"{jnp.shape(action.function)} and {shape} (jax.vmap "
                                 "step for a batch)")
            return apply_raw_action(state, action, self.renderer, self.card_table,
                                    economy=self.game.has_production)
        try:
            check_dense_action(action, ())
        except ValueError as error:
            raise ValueError(f"{error}: Simulator.step and act take one environment's "
                             "action (jax.vmap them for a batch)") from None
        return apply_action(state, action, self.renderer, self.card_table,
                            economy=self.game.has_production)

    def advance(self, state: EnvState, action: DenseAction, loops=None,
                other_action: DenseAction | None = None) -> EnvState:
        """Applies the action (and the other player's, as in `step`) and runs `step_mul`
        (or `loops`, as in `step`) game loops, with no auto-reset: the state part of
        `step` (the SC2 API's `RequestAction` then `RequestStep`)."""
        _, step_key = threefry.split(state.key)

        def acts(state: EnvState, actions) -> EnvState:
            action, other_action = actions
            state = self.act(state, action)
            if other_action is not None:
                return players.mirror(self.act(players.mirror(state), other_action))
            if self.computer:
                return players.mirror(self._computer_acts(players.mirror(state)))
            return state

        state, actions = state.replace(key=step_key), (action, other_action)
        if self.game.players == 2:  # The actions on the leading slots, with the loops.
            return self._advance(state, loops, acts, actions)
        return self._advance(acts(state, actions), loops)

    def _computer_acts(self, seen: EnvState) -> EnvState:
        """The built-in AI's command applied to the game as it sees it."""
        start, other_start = self.game.start_cameras(seen.map_state)
        _, natural = self.game.naturals(seen.map_state)
        command = computer.command(seen, self.computer_level, other_start, start, natural,
                                   self.renderer.buildable)
        return apply_raw(seen, command, self.renderer, self.card_table,
                         economy=self.game.has_production)

    def episode_over(self, state: EnvState, params: EnvParams):
        """bool: the episode has ended (a LAST timestep was, or will be, emitted)."""
        limit = params.game_steps_per_episode
        truncated = (limit > 0) & (state.game_loop >= limit)
        return (state.outcome != Outcome.RUNNING) | truncated

    def observe(self, state: EnvState, previous: dict | None = None) -> dict:
        """The padded observation of a state (`previous`: as in `step`).

        On maps with `slot_sizes`, rendered from the leading slots in use: the slots
        past the last living unit hold nothing the player can see.
        """
        self._check_previous(previous)
        return self._observe(state, previous)

    def _observe(self, state: EnvState, previous: dict | None) -> dict:
        """`observe` with `previous` already checked."""
        layers = None if previous is None else {
            k: previous[k] for k in ("feature_screen", "feature_minimap")}
        sizes = self.game.slot_sizes if self.use_slot_sizes else None
        if sizes is None:
            return observe(state, self.renderer, self.card_table, layers,
                           self.game.has_production)
        return smallest_fit(slots_in_use(state.units.alive), sizes, self._observe_leading,
                            (state, layers))

    def _observe_leading(self, size: int, operand) -> dict:
        state, previous = operand
        units = leading_slots(state.units, size)
        return observe(state.replace(units=units), self.renderer, self.card_table, previous,
                       self.game.has_production)

    # Internals.

    def _check_previous(self, previous: dict | None):
        """Raises ValueError unless `previous` is None or has this simulator's unbatched
        feature layers."""
        if previous is None:
            return
        spec = self.observation_spec()
        for key in ("feature_screen", "feature_minimap"):
            layers = previous.get(key) if isinstance(previous, dict) else None
            want = spec[key]
            if (layers is None or tuple(layers.shape) != tuple(want.shape)
                    or layers.dtype != want.dtype):
                got = None if layers is None else f"{layers.dtype}{list(layers.shape)}"
                raise ValueError(f"previous[{key!r}] must be {want.dtype}{list(want.shape)} "
                                 f"(an unbatched observation of this simulator), got {got}")

    def _timestep(self, state, step_type, reward, discount, previous=None):
        return dm_env.TimeStep(step_type=step_type, reward=reward, discount=discount,
                               observation=self._observe(state, previous))

    def _reward(self, old: EnvState, new: EnvState, ended):
        if self.score_index == -1:  # The outcome.
            outcome = {Outcome.VICTORY: 1.0, Outcome.DEFEAT: -1.0}
            value = sum(jnp.where(new.outcome == o, v, 0.0) for o, v in outcome.items())
            return jnp.where(ended, value, 0.0)
        return (self._score(new) - self._score(old)).astype(jnp.float32)

    def _score(self, state: EnvState):
        if self.score_index == BLIZZARD_SCORE:
            return score.blizzard_score(state)
        return state.score_cumulative.at[0].set(state.score)[self.score_index]

    def _initial_state(self, key) -> EnvState:
        init_key, state_key = threefry.split(key)
        units, map_state, next_tag = self.game.init(init_key)
        h, w = self.game.geometry.size[1], self.game.geometry.size[0]
        cameras = jnp.asarray(self.game.start_cameras(map_state), jnp.float32)
        state = EnvState(
            units=units, camera=cameras[0],
            game_loop=jnp.int32(0), score=jnp.int32(0),
            score_cumulative=jnp.zeros(NUM_SCORE_CUMULATIVE, jnp.int32),
            score_by_vital=jnp.zeros((3, 3), jnp.float32),
            minerals=jnp.int32(self.game.starting_minerals), vespene=jnp.int32(0),
            researched=jnp.zeros(len(research.Research), bool),
            collection_rate=jnp.zeros(2, jnp.float32),
            explored=jnp.zeros((h, w), bool), next_tag=jnp.int32(next_tag),
            last_action=jnp.int32(-1), action_result=jnp.int32(0),
            outcome=jnp.int32(Outcome.RUNNING), episode_step=jnp.int32(0),
            map_state=map_state, key=state_key)
        if self.game.players == 2:
            state = state.replace(other=players.side_of(state, player_id=2).replace(
                camera=cameras[1]))
        return self.game.on_start(_for_each_player(state, self._explore))

    def _advance(self, state: EnvState, count=None, acts=None, actions=None) -> EnvState:
        """Applies the actions (`acts(state, actions) -> state`, or None) and runs the
        step's game loops (`advance`), both on the leading slots in use where the map has
        slot sizes. `advance` gives `acts` on the melee maps, whose actions over every
        slot (the computer's search for building sites, the production checks) cost
        more than compiling them for each slot size; on the mini-games (at most 200
        slots) that compilation costs 45% more and the step runs no faster."""
        game = self.game
        buildable = self.renderer.buildable
        two = state.other is not None
        tags = state.units.tag

        def one_loop(_, carry):
            state, heading, last = carry
            running = state.outcome == Outcome.RUNNING
            key, loop_key = threefry.split(state.key)
            other = state.other
            sides = (state, other) if two else (state,)
            researched = jnp.stack([side.researched for side in sides])  # [P, R]
            units, events = game_loop(state.units, loop_key, game.geometry.playable,
                                      bursts=game.has_bursts, workers=game.has_workers,
                                      combat=game.has_enemies,
                                      colliders=game.collider_slots,
                                      field_slots=game.field_slots,
                                      team_split=game.team_split,
                                      static_slots=game.resource_slots,
                                      jitter_slots=game.num_slots,
                                      sized=game.slot_sizes is not None, face=False,
                                      air=game.has_air,
                                      researched=researched if game.has_production else None)
            income = jnp.stack([events.minerals, events.vespene], axis=-1).astype(jnp.int32)
            banks = jnp.stack([jnp.stack([side.minerals, side.vespene]) for side in sides]
                              ) + income[:len(sides)]
            next_tag, spent = state.next_tag, jnp.zeros_like(banks)
            if game.has_production:
                units, expired = calldown.expire(units)
                events = events._replace(died=events.died | expired)
                units, banks, next_tag, spent, created, finished = _production(
                    units, banks, next_tag, buildable)
                researched = researched | finished
                units = research.shield_health(units, researched, finished, created)
                events = events._replace(created=created)
            new = state.replace(units=units, key=key, game_loop=state.game_loop + 1,
                                score_by_vital=_vital(state.score_by_vital, events, 0),
                                minerals=banks[0, 0], vespene=banks[0, 1],
                                researched=researched[0],
                                next_tag=next_tag)
            new = score.after_loop(new, state.units, events.died, events.minerals[0],
                                   events.vespene[0], spent[0])
            if two:
                cumulative, rate = score.tally(
                    players.swap_owners(units), players.swap_owners(state.units),
                    other.score_cumulative, other.collection_rate, events.died,
                    events.minerals[1], events.vespene[1], spent[1])
                new = new.replace(other=other.replace(
                    minerals=banks[1, 0], vespene=banks[1, 1], researched=researched[1],
                    score_by_vital=_vital(other.score_by_vital, events, 1),
                    score_cumulative=cumulative, collection_rate=rate))
            new = game.on_loop(new, events)
            timer = (new.game_loop >= game.time_limit_loops) & (new.outcome == Outcome.RUNNING)
            new = new.replace(outcome=jnp.where(timer, int(game.timer_outcome), new.outcome))
            frozen = state.replace(game_loop=state.game_loop + 1)
            new = jax.tree_util.tree_map(lambda a, b: jnp.where(running, a, b), new, frozen)
            # Each unit's last turn; a slot whose unit was replaced (a new tag) starts
            # afresh. Facing is set from it after the loops (`dynamics.facing_of`).
            turns = running & turned(events.heading)
            heading = jnp.where(turns[:, None], events.heading, heading)
            heading = jnp.where((new.units.tag == state.units.tag)[:, None], heading, 0.0)
            return new, heading, last | new.units.alive[-1]

        def loops(operand):
            """The game loops, and whether the units' last slot stayed free unless it
            was in use from the start (`_on_leading_slots`). A static count is a scan;
            a run-time one a while loop with the same body. Every traced input comes in
            `operand` (`smallest_fit`)."""
            state, actions, count = operand
            start = state.units.alive[-1]
            state = state if acts is None else acts(state, actions)
            state, heading, last = jax.lax.fori_loop(
                0, self.step_mul if count is None else count, one_loop,
                (state, jnp.zeros_like(state.units.pos), jnp.bool_(False)))
            units = state.units
            state = state.replace(units=units.replace(facing=facing_of(heading, units.facing)))
            return state, ~last | start

        sizes = self.game.slot_sizes if self.use_slot_sizes else None
        if sizes is None:
            state = loops((state, actions, count))[0]
        else:
            state = smallest_fit(self.slots_needed(state.units), sizes,
                                 functools.partial(_on_leading_slots, loops),
                                 (state, actions, count), checked=True)
        state = game.on_step(state.replace(episode_step=state.episode_step + 1))
        if two:  # The other player's selection and groups lose the units that died or
            # were replaced in their slots.
            other = state.other
            same = state.units.alive & (state.units.tag == tags)
            state = state.replace(other=other.replace(
                selected=other.selected & same, groups=jnp.where(same, other.groups, 0)))
        return _for_each_player(state, lambda s: self._explore(score.after_step(s)))

    def slots_needed(self, units) -> jax.Array:
        """int32: the leading slots an agent step's game loops are first tried on: those
        in use, and room for the units the step can create: on maps with production one
        slot per unit of either player that can create one (`production.creators`;
        each makes at most one in `production.MIN_BUILD_LOOPS` loops), and the
        script's `spawn_room`. An action that creates a unit (an add-on, a MULE) takes
        the first free slot; where that is the last of the cut, the step runs again on
        more slots.

        The room is a guess that holds for most steps (a wave can follow another
        within a step; a long step can train several units), not a bound: a run whose
        last slot fills is run again on more slots (`_on_leading_slots`)."""
        need = slots_in_use(units.alive) + self.game.spawn_room
        if self.game.has_production:
            need = need + jnp.sum(production.creators(units), dtype=jnp.int32)
        if self.game.players == 2:
            need = need + jnp.sum(production.creators(players.swap_owners(units)),
                                  dtype=jnp.int32)
        return need

    def _explore(self, state: EnvState) -> EnvState:
        """Marks the map cells the player's units see as explored (fog maps only)."""
        if not self.game.fog:
            return state
        w, h = self.game.geometry.size
        xs = jnp.arange(w, dtype=jnp.float32) + 0.5
        ys = h - 1 - jnp.arange(h, dtype=jnp.float32) + 0.5
        return state.replace(explored=state.explored | sight_grid(state.units, xs, ys, 1.0,
                                                                    self.game.own_slots))


def _for_each_player(state: EnvState, update) -> EnvState:
    """`update(state)` for the player, then on two-player maps for the other player on
    the game as it sees it (`players.mirror`)."""
    state = update(state)
    return state if state.other is None else players.mirror(update(players.mirror(state)))


def _production(units, banks, next_tag, buildable):
    """A game loop's production for each player, the player's first (on two-player maps
    the other's on the units with their owners swapped: `players`), with lifted
    structures landing. One program serves both players (a scan over them).

    Args:
      units: the units.
      banks: int32[P, 2] each player's minerals and vespene.
      next_tag: int32 the next unit tag.
      buildable: bool[H, W] the map's buildable cells.

    Returns:
      (units, banks, next_tag, spent int32[P, 2], created bool[N], finished bool[P, R]
      the research finished).
    """
    def one_player(carry, args):
        units, next_tag, created = carry
        p, bank = args
        view = players.swap_owners_if(units, p == 1)
        economy = production.production_loop(view, bank, next_tag, buildable)
        units = players.swap_owners_if(liftoff.land_arrivals(economy.units, buildable), p == 1)
        return ((units, economy.next_tag, created | economy.created),
                (economy.bank, economy.spent, economy.researched))

    count = banks.shape[0]
    carry = (units, next_tag, jnp.zeros(units.num_slots, bool))
    if count == 1:
        (units, next_tag, created), out = one_player(carry, (0, banks[0]))
        out = jax.tree.map(lambda x: x[None], out)
    else:
        (units, next_tag, created), out = jax.lax.scan(
            one_player, carry, (jnp.arange(count), banks))
    new_banks, spent, finished = out
    return units, new_banks, next_tag, spent, created, finished


def _vital(vital, events, p: int):
    """float32[3, 3] `score_by_vital` after a loop: player p's damage dealt and taken
    (`LoopEvents`) added."""
    vital = vital.reshape(-1)  # [3, 3]: life dealt, life taken.
    return set_static(vital, {0: vital[0] + events.damage_dealt[p],
                              3: vital[3] + events.damage_taken[p]}).reshape(3, 3)


def _on_leading_slots(run, size: int, operand):
    """`run((state, *rest))` for `operand` (state, *rest), with the state's units cut to
    their first `size` slots; the other slots are kept as they are (the caller knows
    they are dead).

    `run` returns (state, fits). The cut run is the whole run where no unit needs a
    slot past the cut: where one would, every slot of the cut is taken (units are
    created in the first free slots, and none dies in a loop after its creations), so
    the last slot fills. `fits` is False where it did, unless it was in use from the
    start (then the step can create nothing: `Simulator.slots_needed` leaves room).
    """
    state, rest = operand[0], tuple(operand[1:])
    if size == state.units.num_slots:
        return run(operand)
    put = lambda full, head: full.at[:size].set(head)  # noqa: E731
    other = state.other
    cut = state.replace(units=leading_slots(state.units, size))
    if other is not None:  # The other player's selection and groups are per slot too.
        cut = cut.replace(other=other.replace(selected=other.selected[:size],
                                              groups=other.groups[:size]))
    out, fits = run((cut, *rest))
    out = out.replace(units=jax.tree.map(put, state.units, out.units))
    if other is not None:
        out = out.replace(other=out.other.replace(
            selected=put(other.selected, out.other.selected),
            groups=put(other.groups, out.other.groups)))
    return out, fits
