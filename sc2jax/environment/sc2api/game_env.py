"""A game reached through the StarCraft II API, as a `dm_env` environment.

`GameEnv` gives the same observations (PySC2's layout, `SC2Env`'s spec) and takes the
same actions (`FunctionCall` or an unbatched `DenseAction`) as the simulator's `SC2Env`,
so agents cannot tell the backends apart. It drives a `Controller`: the real game
(`launcher.launch`) or the simulator's SC2-API server (`server.py`).

The flow is PySC2's `SC2Env` (reference/pysc2_facts.md §5):
- the first `reset` creates and joins the game; later ones restart it (one player) or
  leave and create it again (with a bot);
- `step` sends the action, steps `step_mul` game loops and observes;
- rewards are the change of `score_cumulative[score_index]`, or with `score_index=-1`
  the outcome (+1 victory, -1 defeat, 0 tie) on the last step; times `score_multiplier`;
- the episode ends (LAST, discount 0) when the game reports a result, or is truncated
  (LAST, discount kept unless `discount_zero_after_timeout`) at
  `game_steps_per_episode` game loops.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import os
import pathlib
import time
from collections.abc import Callable, Sequence
from typing import NamedTuple

import dm_env
import numpy as np

from sc2jax.atomic import atomic_write
from sc2jax.checks import check_known
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.dense import DenseAction, check_dense_action, from_dense
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, validate_function_call
from sc2jax.environment.interface.layout import named, to_padded_layout
from sc2jax.environment.interface.map_names import MINI_GAMES as MAPS
from sc2jax.environment.interface.players import BotBuild, Difficulty, Race
from sc2jax.environment.sc2api import proto_actions, proto_observation
from sc2jax.environment.sc2api.controller import Controller
from sc2jax.environment.sc2api.protos import sc2api

RACES = {race.name: race.value for race in Race}
DIFFICULTIES = {level.name: level.value for level in Difficulty}
BUILDS = {build.name: build.value for build in BotBuild}
END_OF_GAME_LOOP = 2 ** 32 - 1
"""The game loop of the stub observation the game sends after the game ended."""


class Bot(NamedTuple):
    """A built-in AI opponent (`sc2api.PlayerSetup` of type Computer).

    Attributes:
      race: "random", "terran", "zerg" or "protoss".
      difficulty: 1..10, or a name ("very_easy" .. "cheat_insane").
      build: "random", "rush", "timing", "power", "macro" or "air".
    """

    race: str = "random"
    difficulty: int | str = "very_easy"
    build: str = "random"

    def setup(self):
        """The `sc2api.PlayerSetup`; raises ValueError for a bad field."""
        check_known("bot race", [self.race], RACES)
        check_known("bot build", [self.build], BUILDS)
        difficulty = DIFFICULTIES.get(self.difficulty, self.difficulty)
        if isinstance(difficulty, bool) or difficulty not in range(1, 11):
            raise ValueError(f"bot difficulty {self.difficulty!r} is not allowed; expected "
                             f"1..10 or one of {sorted(DIFFICULTIES)}")
        return sc2api.PlayerSetup(type=sc2api.PlayerType.Value("Computer"),
                                  race=RACES[self.race], difficulty=difficulty,
                                  ai_build=BUILDS[self.build])


class GameEnv(dm_env.Environment):
    """One agent in a game over the SC2 API.

    Args:
      connect: returns a connected `Controller` (called on the first reset, and again
        after `close`).
      map_name: the map; a mini-game name or any map the game knows.
      map_path: the map's path for `create_game` (default `mini_games/<map>.SC2Map`).
      map_data: the map file's bytes, sent with the path (optional).
      screen_size, minimap_size, screen_features, minimap_features, use_feature_units,
        use_raw_units, max_units: the observation format, as for `make` (the unit lists
        come from the game's raw data; `max_units` only bounds `GameEnvBatch`'s padding).
      race: the agent's race.
      bot: an opponent (`Bot`), or None (the mini-games have none).
      step_mul: game loops per agent step.
      game_steps_per_episode: truncate episodes at this game loop (0: never).
      score_index: the reward (see the module docstring); None: 0 on the mini-games,
        -1 (win/loss) on other maps.
      score_multiplier, discount, discount_zero_after_timeout: as in PySC2.
      ensure_available_actions: raise ValueError for an unavailable function.
      disable_fog: create the game without fog of war.
      random_seed: the game's random seed (None: the game picks).
      save_replay_episodes: save a replay every this many episodes (0: never) into
        `replay_dir`.
      hide_specific_actions: expose specific abilities through general functions.

    Raises:
      ValueError: for a bad setting, before anything connects.
    """

    def __init__(self, connect: Callable[[], Controller], map_name: str, *,
                 map_path: str | None = None, map_data: bytes = b"",
                 screen_size: specs.Size = 64, minimap_size: specs.Size = 64,
                 screen_features: Sequence[str] | None = None,
                 minimap_features: Sequence[str] | None = None,
                 use_feature_units: bool = False, use_raw_units: bool = False,
                 max_units: int = 64, race: str = "terran",
                 bot: Bot | None = None, step_mul: int = 8, game_steps_per_episode: int = 0,
                 score_index: int | None = None, score_multiplier: float = 1.0,
                 discount: float = 1.0, discount_zero_after_timeout: bool = False,
                 ensure_available_actions: bool = True, disable_fog: bool = False,
                 random_seed: int | None = None, save_replay_episodes: int = 0,
                 replay_dir: str | os.PathLike | None = None,
                 hide_specific_actions: bool = True):
        if not isinstance(map_name, str) or not map_name:
            raise ValueError(f"map_name must be a non-empty str, got {map_name!r}")
        check_known("race", [race], RACES)
        self._bot_setup = bot.setup() if bot is not None else None
        for name, value, low in (("step_mul", step_mul, 1),
                                 ("game_steps_per_episode", game_steps_per_episode, 0),
                                 ("save_replay_episodes", save_replay_episodes, 0)):
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"{name} must be an int >= {low}, got {value!r}")
        if score_index is None:
            score_index = 0 if map_name in MAPS else -1
        if not isinstance(score_index, int) or not -1 <= score_index < 13:
            raise ValueError(f"score_index must be -1 (win/loss) or in 0..12, got "
                             f"{score_index!r}")
        if not 0.0 <= discount <= 1.0:
            raise ValueError(f"discount must be in [0, 1], got {discount!r}")
        if save_replay_episodes and not replay_dir:
            raise ValueError("save_replay_episodes needs replay_dir")
        self.fmt = specs.ObservationFormat(
            screen_size=screen_size, minimap_size=minimap_size,
            screen_features=None if screen_features is None else tuple(screen_features),
            minimap_features=None if minimap_features is None else tuple(minimap_features),
            use_feature_units=use_feature_units, use_raw_units=use_raw_units,
            max_units=max_units)
        self.map_name = map_name
        self._connect = connect
        self._map_path = map_path or f"mini_games/{map_name}.SC2Map"
        self._map_data = map_data
        self._race = RACES[race]
        self._step_mul = step_mul
        self._limit = game_steps_per_episode
        self._score_index = score_index
        self._multiplier = float(score_multiplier)
        self._discount = float(discount)
        self._discount_zero_after_timeout = discount_zero_after_timeout
        self._ensure_available = ensure_available_actions
        self._disable_fog = disable_fog
        self._seed = random_seed
        self._replay_every = save_replay_episodes
        self._replay_dir = pathlib.Path(replay_dir) if replay_dir else None
        self._hide_specific = hide_specific_actions
        self._controller: Controller | None = None
        self._in_game = False
        self._episodes = 0
        self._last_obs: dict | None = None
        self._last_step_type = None
        self._races = (self._race, 0)
        self._game_map_name = map_name
        self._map_size: tuple[int, int] | None = None

    # dm_env.

    def observation_spec(self) -> dict:
        return specs.observation_spec(self.fmt, padded=False)

    def action_spec(self) -> DenseAction:
        return specs.action_spec(self.fmt.screen_size, self.fmt.minimap_size)

    def reset(self) -> dm_env.TimeStep:
        with self._dropping_on_failure():
            if self._controller is None:
                self._controller = self._connect()
            if not self._in_game:
                self._create()
            elif self._bot_setup is None:
                self._controller.restart()
            else:
                self._controller.leave()
                self._create()
            observation, _ = self._observe()
        self._episodes += 1
        self._last_step_type = dm_env.StepType.FIRST
        return dm_env.TimeStep(dm_env.StepType.FIRST, 0.0, 0.0, observation)

    def step(self, action: FunctionCall | DenseAction) -> dm_env.TimeStep:
        if self._last_step_type is None or self._last_step_type == dm_env.StepType.LAST:
            return self.reset()
        call = self._to_call(action)
        if self._ensure_available and call.function not in self._last_obs["available_actions"]:
            raise ValueError(f"function {call.function}/{FUNCTIONS[call.function].name} is not "
                             f"available; available: "
                             f"{self._last_obs['available_actions'].tolist()}")
        previous = self._last_obs
        with self._dropping_on_failure():
            controller = self._controller
            if controller.status != sc2api.Status.Value("ended"):
                controller.actions([proto_actions.to_proto(call)])
                controller.step(self._step_mul)
            observation, result = self._observe()
        game_loop = int(observation["game_loop"][0])
        truncated = self._limit > 0 and game_loop >= self._limit
        if result is not None or truncated:
            step_type = dm_env.StepType.LAST
            terminal = result is not None or self._discount_zero_after_timeout
            discount = 0.0 if terminal else self._discount
            self._after_episode()
        else:
            step_type, discount = dm_env.StepType.MID, self._discount
        if self._score_index >= 0:
            reward = float(observation["score_cumulative"][self._score_index]
                           - previous["score_cumulative"][self._score_index])
        else:
            reward = {1: 1.0, 2: -1.0}.get(result, 0.0) if step_type == dm_env.StepType.LAST \
                else 0.0
        self._last_step_type = step_type
        return dm_env.TimeStep(step_type, reward * self._multiplier, discount, observation)

    def close(self) -> None:
        """Leaves the game and quits it (the process or server exits)."""
        if self._controller is not None:
            self._controller.quit()
        self._controller, self._in_game, self._last_step_type = None, False, None

    # Internals.

    @contextlib.contextmanager
    def _dropping_on_failure(self):
        """On a lost connection or a timeout, forgets the game (the next `reset`
        connects again) and re-raises."""
        try:
            yield
        except (ConnectionError, TimeoutError):
            controller, self._controller = self._controller, None
            self._in_game, self._last_step_type = False, None
            if controller is not None:
                controller.quit()
            raise

    def _create(self) -> None:
        controller = self._controller
        players = [sc2api.PlayerSetup(type=sc2api.PlayerType.Value("Participant"),
                                      race=self._race)]
        if self._bot_setup is not None:
            players.append(self._bot_setup)
        controller.create_game(map_path=self._map_path, map_data=self._map_data,
                               players=players, disable_fog=self._disable_fog,
                               random_seed=self._seed)
        controller.join_game(self._interface_options(), race=self._race)
        info = controller.game_info()
        self._game_map_name = info.map_name or self.map_name
        self._map_size = (info.start_raw.map_size.x, info.start_raw.map_size.y)
        races = {p.player_id: p.race_requested for p in info.player_info
                 if p.type != sc2api.PlayerType.Value("Observer")}
        home = races.get(1, self._race)
        away = next((race for pid, race in races.items() if pid != 1), 0)
        self._races = (home, away)
        self._in_game = True

    def _interface_options(self):
        options = sc2api.InterfaceOptions(
            raw=self.fmt.use_feature_units or self.fmt.use_raw_units, score=True)
        layers = options.feature_layer
        layers.width = 24
        layers.resolution.x, layers.resolution.y = self.fmt.screen_size
        layers.minimap_resolution.x, layers.minimap_resolution.y = self.fmt.minimap_size
        return options

    def _observe(self) -> tuple[dict, int | None]:
        """The observation and the game's result for the agent (None while running)."""
        response = self._controller.observe()
        result = response.player_result[0].result if response.player_result else None
        if response.observation.game_loop == END_OF_GAME_LOOP and self._last_obs is not None:
            observation = self._last_obs  # The game's end-of-game stub.
        else:
            observation = named(proto_observation.decode(
                response, self.fmt, self._game_map_name, self._races, self._hide_specific,
                self._map_size), self.fmt)
        self._last_obs = observation
        return observation, result

    def _after_episode(self) -> None:
        if self._replay_every and self._episodes % self._replay_every == 0:
            data = self._controller.save_replay()
            stamp = time.strftime("%Y-%m-%d-%H-%M-%S", time.gmtime())
            path = self._replay_dir / f"{self.map_name}_{stamp}_{self._episodes}.SC2Replay"
            with atomic_write(path, "wb") as f:
                f.write(data)

    def _to_call(self, action) -> FunctionCall:
        if isinstance(action, DenseAction):
            check_dense_action(action, ())
            action = from_dense(action)
        if not isinstance(action, FunctionCall):
            raise TypeError(f"GameEnv.step takes a FunctionCall or a DenseAction, got "
                            f"{type(action).__name__}")
        return validate_function_call(action, self.fmt.types)


class GameEnvBatch(dm_env.Environment):
    """Several `GameEnv`s (game processes, or servers standing in for them) stepped
    together, as one batched environment in `BatchedSC2Env`'s layout: padded
    observations with a leading batch dimension, a batched `DenseAction` in. Each game
    starts a new episode on the step after its LAST timestep (its own auto-reset).

    The games step in parallel threads (each waits on its own process), so a
    `HostActor` can act for all of them with one batched policy call.

    Args:
      envs: the games; they must share one observation format.
    """

    def __init__(self, envs: Sequence[GameEnv]):
        envs = list(envs)
        if not envs or not all(isinstance(e, GameEnv) for e in envs):
            raise ValueError(f"GameEnvBatch needs one or more GameEnvs, got {envs!r}")
        if len({e.fmt for e in envs}) != 1:
            raise ValueError("the games of a GameEnvBatch must share one observation format")
        self.envs, self.fmt, self.num_envs = envs, envs[0].fmt, len(envs)
        self._pool = concurrent.futures.ThreadPoolExecutor(len(envs), "sc2jax-game")

    def observation_spec(self) -> dict:
        """The spec of one game's padded observation (without the batch dim)."""
        return specs.observation_spec(self.fmt, padded=True)

    def action_spec(self) -> DenseAction:
        return specs.action_spec(self.fmt.screen_size, self.fmt.minimap_size)

    def reset(self) -> dm_env.TimeStep:
        return self._stack(list(self._pool.map(lambda env: env.reset(), self.envs)))

    def step(self, action: DenseAction) -> dm_env.TimeStep:
        check_dense_action(action, (self.num_envs,))
        calls = from_dense(action)
        return self._stack(list(self._pool.map(lambda env, call: env.step(call), self.envs,
                                               calls)))

    def close(self) -> None:
        list(self._pool.map(lambda env: env.close(), self.envs))
        self._pool.shutdown()

    def _stack(self, timesteps: list[dm_env.TimeStep]) -> dm_env.TimeStep:
        observations = [to_padded_layout(t.observation, self.fmt) for t in timesteps]
        return dm_env.TimeStep(
            step_type=np.array([t.step_type for t in timesteps], np.int32),
            reward=np.array([t.reward for t in timesteps], np.float32),
            discount=np.array([t.discount for t in timesteps], np.float32),
            observation={k: np.stack([o[k] for o in observations]) for k in observations[0]})
