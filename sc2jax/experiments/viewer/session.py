"""A game that a person plays or watches in the viewer, one step at a time.

`PlaySession` holds one simulator environment: its state, its last timestep, and the
episode so far. A person's inputs arrive as PySC2 `FunctionCall`s (`submit`), checked
exactly as `SC2Env.step` checks an agent's (`validate_function_call`, then the
`available_actions` mask); the next `step` plays the last one submitted, or `no_op`. With
an `agent` (watch mode) the agent chooses every action instead. Each finished episode is
kept as an `Episode` (the reset key and the actions), which replays exactly.

`Playback` serves the steps of a recorded episode in the same form, to scrub through
(a `Timeline`, as `replays.ReplayPlayback` of a human replay).

They hand out `Frame`s: the pictures and numbers the page shows for one step. All
methods are thread-safe (the page's requests and the stepping loop share a session).
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable, Sequence
from typing import Any

import dm_env
import jax
import numpy as np

from sc2jax.environment.engine.compiled import compiled
from sc2jax.environment.engine.human_view import HumanView
from sc2jax.environment.engine.simulator import EnvParams, Simulator
from sc2jax.environment.episodes import Episode, replay_whole
from sc2jax.environment.interface.dense import DenseAction, to_dense
from sc2jax.environment.interface.features import Feature
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, validate_function_call
from sc2jax.experiments.viewer.frames import action_text, layer_format, pictures
from sc2jax.experiments.viewer.inputs import call_for_click

NO_OP = FunctionCall(FUNCTIONS.no_op.id, [])

Agent = Callable[[jax.Array, Any, dict, np.ndarray], tuple[Any, DenseAction]]
"""`evaluation.HostAct`: (key, carry, observation [1, ...], first bool[1]) -> (carry,
DenseAction [1])."""


@dataclasses.dataclass
class Frame:
    """What the page shows for one step.

    Attributes:
      view: uint8[H, W, 3] the human view.
      minimap: uint8[h, w, 3] the human view of the whole map.
      panels: feature layer -> uint8[s, s, 3] the layer in colour.
      values: feature layer -> int32[s, s] the layer's values (for legends).
      status: numbers and names for the page (JSON-able).
    """

    view: np.ndarray
    minimap: np.ndarray
    panels: dict[Feature, np.ndarray]
    values: dict[Feature, np.ndarray]
    status: dict


class _Drawing:
    """The jitted pictures of one simulator: view, minimap, layer panels."""

    def __init__(self, sim: Simulator, width: int, layers: Sequence[Feature]):
        self.sim = sim
        self.layers = tuple(layers)
        self.pictures = pictures(sim, width, self.layers)
        w, h = sim.game.geometry.size
        minimap = HumanView(sim, max(8, width // 2), (0.0, 0.0, float(w), float(h)))
        self.minimap_view = minimap
        self._draw = jax.jit(lambda state, obs: (self.pictures(state, obs),
                                                 minimap.draw(state)))

    def __call__(self, state, observation, status: dict) -> Frame:
        (view, panels, values), minimap = jax.device_get(self._draw(state, observation))
        return Frame(view, minimap, dict(zip(self.layers, panels)),
                     dict(zip(self.layers, values)), status)


def available_functions(mask: np.ndarray) -> list[dict]:
    """The available functions as the page lists them: id, name and argument names."""
    return [{"id": int(f), "name": FUNCTIONS[int(f)].name,
             "args": [a.name for a in FUNCTIONS[int(f)].args]}
            for f in np.flatnonzero(mask)]


class PlaySession:
    """One mini-game played by a person, or watched with an agent.

    Args:
      sim: the simulator (its format must render `layers`).
      seed: the first episode's seed; each episode's reset key follows from it.
      layers: the feature layers shown.
      width: the human view's width in pixels.
      agent: None (a person plays), or an `Agent` that chooses every action.
      agent_carry: the agent's initial carry (None for feed-forward agents).
      agent_name: who plays, stored in the episodes ("human" without an agent).
      params: the episode parameters.
    """

    def __init__(self, sim: Simulator, seed: int = 0, layers: Sequence[Feature] = (),
                 width: int = 384, agent: Agent | None = None, agent_carry: Any = None,
                 agent_name: str | None = None, params: EnvParams | None = None):
        self.sim = sim
        self.params = params or EnvParams()
        self.agent, self._initial_carry = agent, agent_carry
        self.agent_name = agent_name or ("human" if agent is None else "agent")
        self._reset_fn, self._step_fn = compiled(sim, False)
        self._drawing = _Drawing(sim, width, layers)
        self._lock = threading.RLock()
        self._key = jax.random.PRNGKey(seed)
        self._pending: FunctionCall | None = None
        self._version = 0
        self.episodes: list[Episode] = []
        self.last_call: str = ""
        self.reset()

    # Episodes.

    def reset(self) -> None:
        """Starts a new episode; the current one is kept in `episodes` if it had ended,
        else dropped."""
        with self._lock:
            timestep = getattr(self, "_timestep", None)
            if timestep is not None and int(timestep.step_type) == dm_env.StepType.LAST:
                self._finish()
            self._key, episode_key, self._act_key = jax.random.split(self._key, 3)
            self._episode_key = np.asarray(episode_key, np.uint32)
            self._state, self._timestep = jax.device_get(
                self._reset_fn(self._episode_key, self.params))
            self._actions: list[DenseAction] = []
            self._rewards: list[float] = []
            self._carry = self._initial_carry
            self._pending = None
            self._frame = None
            self._version += 1

    def _finish(self) -> None:
        """Keeps the episode that just ended."""
        actions = DenseAction(*(np.stack(field) for field in zip(*self._actions)))
        self.episodes.append(Episode(
            map_name=self.sim.map_name, screen_size=self.sim.fmt.screen_size,
            minimap_size=self.sim.fmt.minimap_size, step_mul=self.sim.step_mul,
            key=self._episode_key, actions=actions,
            rewards=np.asarray(self._rewards, np.float32), score_index=self.sim.score_index,
            score_multiplier=self.sim.score_multiplier,
            game_steps_per_episode=int(self.params.game_steps_per_episode),
            agent=self.agent_name))

    # Actions.

    @property
    def available(self) -> np.ndarray:
        """bool[573]: the functions available now."""
        return np.asarray(self._timestep.observation["available_actions_mask"])

    def check(self, call: FunctionCall | Sequence) -> FunctionCall:
        """The call normalised, as `SC2Env.step` accepts it.

        Raises:
          ValueError: a bad call (unknown function, bad arguments), or a function that is
            not available now.
        """
        call = validate_function_call(call, self.sim.fmt.types)
        with self._lock:
            if not self.available[call.function]:
                raise ValueError(f"function {call.function}/{FUNCTIONS[call.function].name} "
                                 f"is not available now; available: "
                                 f"{[f['name'] for f in available_functions(self.available)]}")
        return call

    def submit(self, call: FunctionCall | Sequence) -> FunctionCall:
        """Queues a person's call for the next step (it replaces one queued before).
        Raises ValueError as `check`."""
        call = self.check(call)
        with self._lock:
            self._pending = call
        return call

    def click(self, click: dict) -> FunctionCall:
        """Queues the call a click on the page means (`inputs.call_for_click`). Raises
        ValueError for a click that means no available call."""
        with self._lock:
            call = call_for_click(click, self._drawing.pictures.view,
                                  self._drawing.minimap_view,
                                  np.asarray(self._state.camera), self.available)
        return self.submit(call)

    def step(self) -> None:
        """Plays one agent step: the agent's action, else the queued call, else no_op. After
        the episode's last step, starts the next episode instead."""
        with self._lock:
            if int(self._timestep.step_type) == dm_env.StepType.LAST:
                self.reset()
                return
            if self.agent is not None:
                self._act_key, key = jax.random.split(self._act_key)
                obs = jax.tree.map(lambda x: np.asarray(x)[None], self._timestep.observation)
                first = np.asarray([int(self._timestep.step_type) == dm_env.StepType.FIRST])
                self._carry, action = self.agent(key, self._carry, obs, first)
                action = DenseAction(*(np.asarray(a)[0] for a in jax.device_get(action)))
            else:
                call = self._pending or NO_OP
                self._pending = None
                action = to_dense(call, self.sim.fmt.types)
            self.last_call = action_text(action)
            self._state, self._timestep = jax.device_get(
                self._step_fn(self._state, action, self.params))
            self._actions.append(action)
            self._rewards.append(float(self._timestep.reward))
            self._frame = None
            self._version += 1

    # What the page shows.

    def frame(self) -> Frame:
        """The current step's pictures and status (drawn once per step)."""
        with self._lock:
            if self._frame is None:
                self._frame = self._drawing(self._state, self._timestep.observation,
                                            self._status())
            return self._frame

    def _status(self) -> dict:
        rewards = self._rewards
        return {"version": self._version,
                "map": self.sim.map_name, "mode": "watch" if self.agent else "play",
                "agent": self.agent_name, "step": len(rewards),
                "game_loop": int(self._state.game_loop),
                "score": float(np.sum(rewards, dtype=np.float64)),
                "episode": len(self.episodes) + 1,
                "last_scores": [e.score for e in self.episodes[-5:]],
                "last_call": self.last_call,
                "step_type": int(self._timestep.step_type),
                "available": available_functions(self.available),
                "screen_size": list(self.sim.fmt.screen_size),
                "minimap_size": list(self.sim.fmt.minimap_size)}


class Timeline:
    """A recording to scrub through: `seek`, `step` and `frame` over its `length` steps,
    each step's frame drawn once, by the subclass's `_draw(t)`."""

    def __init__(self):
        self._lock = threading.RLock()
        self.position = 0
        self._frame = None

    @property
    def length(self) -> int:
        raise NotImplementedError

    def _draw(self, t: int) -> Frame:
        raise NotImplementedError

    def seek(self, position: int) -> None:
        """Moves to step `position`, clipped to [0, length - 1]."""
        with self._lock:
            position = int(np.clip(position, 0, self.length - 1))
            if position != self.position:
                self.position, self._frame = position, None

    def step(self) -> None:
        """Moves one step on (and stays at the end)."""
        self.seek(self.position + 1)

    def frame(self) -> Frame:
        with self._lock:
            if self._frame is None:
                self._frame = self._draw(self.position)
            return self._frame


class Playback(Timeline):
    """The steps of a recorded episode, to scrub through."""

    def __init__(self, episode: Episode, layers: Sequence[Feature] = (), width: int = 384):
        super().__init__()
        self.episode = episode
        fmt = layer_format(episode.screen_size, episode.minimap_size, layers)
        self.sim = episode.simulator(fmt)
        self._drawing = _Drawing(self.sim, width, layers)
        self._states, timesteps = jax.device_get(replay_whole(episode, fmt))
        self._observations = timesteps.observation
        self._scores = np.cumsum(np.asarray(timesteps.reward), dtype=np.float64)

    @property
    def length(self) -> int:
        """The observations: steps + 1."""
        return self.episode.num_steps + 1

    def _draw(self, t: int) -> Frame:
        state = jax.tree.map(lambda x: x[t], self._states)
        obs = jax.tree.map(lambda x: x[t], self._observations)
        e = self.episode
        action = (action_text(DenseAction(*(a[t] for a in e.actions)))
                  if t < e.num_steps else "")
        return self._drawing(state, obs, {
            "version": t, "map": e.map_name, "mode": "playback", "agent": e.agent,
            "step": t, "length": self.length, "game_loop": int(state.game_loop),
            "score": float(self._scores[t]), "last_call": action,
            "available": available_functions(np.asarray(obs["available_actions_mask"])),
            "screen_size": list(e.screen_size), "minimap_size": list(e.minimap_size)})
