"""PySC2's `pysc2.env.sc2_env`: `SC2Env` with PySC2 v4's constructor, over the simulator.

    env = sc2_env.SC2Env(
        map_name="MoveToBeacon", players=[sc2_env.Agent(sc2_env.Race.terran)],
        agent_interface_format=features.AgentInterfaceFormat(
            feature_dimensions=features.Dimensions(screen=84, minimap=64)),
        step_mul=8)
    timesteps = env.reset()                  # a tuple: one TimeStep per agent
    timesteps = env.step([actions.FUNCTIONS.select_army("select")])

It plays the mini-games with one agent, as Terran. The episodes are those of
`sc2jax.environment.make` with the same settings (the same seed gives the same
episodes); the observations are PySC2's layout with its names.
"""

from __future__ import annotations

import collections
import random
from collections.abc import Sequence

import dm_env

from sc2jax.environment.engine.minigames import check_map
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, Functions
from sc2jax.environment.interface.players import BotBuild, Difficulty, Race
from sc2jax.environment.pysc2.env.environment import StepType, TimeStep
from sc2jax.environment.pysc2.lib import actions
from sc2jax.environment.pysc2.lib.features import (
    ActionSpace,
    AgentInterfaceFormat,
    Dimensions,
    parse_agent_interface_format,
)
from sc2jax.environment.pysc2.lib.named_array import NamedDict
from sc2jax.environment.sc2_env import make

__all__ = ["ActionSpace", "Agent", "AgentInterfaceFormat", "Bot", "BotBuild", "Difficulty",
           "Dimensions", "Race", "SC2Env", "StepType", "TimeStep",
           "parse_agent_interface_format"]


class Agent(collections.namedtuple("Agent", ["race", "name"])):
    """A player the agent controls: its race (or a list to pick from) and name."""

    def __new__(cls, race, name=None):
        return super().__new__(cls, race, name or "<unknown>")


class Bot(collections.namedtuple("Bot", ["race", "difficulty", "build"])):
    """A built-in AI player (the game's; the simulator's mini-games have none)."""

    def __new__(cls, race, difficulty, build=None):
        return super().__new__(cls, race, difficulty, build or BotBuild.random)


class SC2Env:
    """A mini-game on the simulator, with PySC2 v4's constructor and returns.

    Args (keyword only, as PySC2's; see its documentation):
      map_name: a mini-game name, or a list of them (one is picked at each reset).
      players: one `Agent` of race terran or random (the mini-games' player is Terran).
      agent_interface_format: an `AgentInterfaceFormat`, or a list of one.
      discount: the discount of MID steps (and of LAST steps at the time limit).
      discount_zero_after_timeout: a LAST step at the time limit has discount 0.
      step_mul: game loops per agent step (None: 8).
      game_steps_per_episode: the episode's limit in game loops (None or 0: the map's).
      score_index: the reward's `score_cumulative` entry (None: 0, the mini-game score);
        -1 for the outcome.
      score_multiplier: multiplies every reward (None: 1).
      random_seed: the seed (None: a random one).
      ensure_available_actions: raise for an unavailable function (PySC2's default).
      battle_net_map, visualize, realtime, save_replay_episodes, replay_dir,
        replay_prefix, disable_fog, version: must keep PySC2's defaults (the simulator
        has no Battle.net maps, viewer, real time, replays or game versions to choose).

    Raises:
      ValueError: a setting the simulator does not have, or a bad value, naming it,
        before anything is compiled.
    """

    def __init__(self, *, map_name=None, battle_net_map=False, players=None,
                 agent_interface_format=None, discount=1.0, discount_zero_after_timeout=False,
                 visualize=False, step_mul=None, realtime=False, save_replay_episodes=0,
                 replay_dir=None, replay_prefix=None, game_steps_per_episode=None,
                 score_index=None, score_multiplier=None, random_seed=None,
                 disable_fog=False, ensure_available_actions=True, version=None):
        defaults = dict(battle_net_map=False, visualize=False, realtime=False,
                        save_replay_episodes=0, replay_dir=None, replay_prefix=None,
                        disable_fog=False, version=None)
        given = dict(battle_net_map=battle_net_map, visualize=visualize, realtime=realtime,
                     save_replay_episodes=save_replay_episodes, replay_dir=replay_dir,
                     replay_prefix=replay_prefix, disable_fog=disable_fog, version=version)
        changed = [f"{k}={v!r}" for k, v in given.items() if v != defaults[k]]
        if changed:
            raise ValueError(f"{', '.join(changed)}: not supported by the simulator; leave "
                             f"at PySC2's default")
        self._maps = _check_maps(map_name)
        _check_players(players)
        self._interface = _check_interface(agent_interface_format)
        dims = self._interface.feature_dimensions
        self._fmt = specs.ObservationFormat(
            screen_size=dims.screen, minimap_size=dims.minimap,
            use_feature_units=self._interface.use_feature_units,
            use_raw_units=self._interface.use_raw_units)
        self._settings = dict(
            screen_size=dims.screen, minimap_size=dims.minimap,
            step_mul=8 if step_mul is None else step_mul,
            use_feature_units=self._interface.use_feature_units,
            use_raw_units=self._interface.use_raw_units,
            score_index=0 if score_index is None else score_index,
            score_multiplier=1.0 if score_multiplier is None else score_multiplier,
            discount=discount, ensure_available_actions=ensure_available_actions,
            game_steps_per_episode=game_steps_per_episode or 0,
            allow_cheating_layers=self._interface.allow_cheating_layers)
        self._discount_zero_after_timeout = bool(discount_zero_after_timeout)
        self._rng = random.Random(random_seed)
        self._seed = random_seed
        self._envs = {}
        if len(self._maps) == 1:  # Checks the settings now, as PySC2 does at creation.
            self._envs[self._maps[0]] = self._make(self._maps[0])
        self._env = None
        self._last = None

    # PySC2's interface.

    def observation_spec(self) -> tuple[NamedDict, ...]:
        """One dict per agent: each observation's shape, 0 for a variable length."""
        spec = NamedDict()
        for key, array in specs.observation_spec(self._fmt, padded=False).items():
            if isinstance(array, specs.StringSpec):
                continue
            variable = isinstance(array, specs.VariableLengthArray)
            spec[key] = ((0,) + tuple(array.shape[1:])) if variable else tuple(array.shape)
        return (spec,)

    def action_spec(self) -> tuple[actions.ValidActions, ...]:
        """One `ValidActions` per agent: the argument types at the agent's resolutions,
        and every function with its arguments of those types."""
        types = self._fmt.types
        functions = Functions([f._replace(args=tuple(types[a.id] for a in f.args))
                               for f in FUNCTIONS])
        return (actions.ValidActions(types, functions),)

    def reset(self) -> tuple[TimeStep, ...]:
        """Starts an episode (on a map picked at random, if several)."""
        name = self._rng.choice(self._maps)
        if name not in self._envs:
            self._envs[name] = self._make(name)
        self._env = self._envs[name]
        self._last = self._env.reset()
        return (self._last,)

    def step(self, actions: Sequence[FunctionCall] | FunctionCall,
             step_mul: int | None = None) -> tuple[TimeStep, ...]:
        """Applies one action per agent (a list of one `FunctionCall`) and advances
        `step_mul` game loops. After a LAST timestep, starts a new episode instead.

        Raises:
          ValueError: not one action, an unavailable function (with
            `ensure_available_actions`), or a `step_mul` other than the environment's.
        """
        if step_mul is not None and step_mul != self._settings["step_mul"]:
            raise ValueError(f"step_mul={step_mul!r} per step is not supported; this "
                             f"environment steps {self._settings['step_mul']} game loops")
        if isinstance(actions, FunctionCall):
            actions = [actions]
        if len(actions) != 1:
            raise ValueError(f"step takes one action per agent (1 agent), got "
                             f"{len(actions)}")
        if self._last is None or self._last.last():
            return self.reset()
        timestep = self._env.step(actions[0])
        if (self._discount_zero_after_timeout and timestep.last()
                and timestep.discount != 0):
            timestep = timestep._replace(discount=0.0)
        self._last = timestep
        return (timestep,)

    def close(self) -> None:
        self._envs, self._env, self._last = {}, None, None

    def __enter__(self) -> SC2Env:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # Internals.

    def _make(self, map_name: str) -> dm_env.Environment:
        seed = None if self._seed is None else self._seed + self._maps.index(map_name)
        return make(map_name, seed=seed, **self._settings)


def _check_maps(map_name) -> list[str]:
    if map_name is None:
        raise ValueError("map_name is required: a mini-game name or a list of them")
    maps = [map_name] if isinstance(map_name, str) else list(map_name)
    if not maps or not all(isinstance(m, str) for m in maps):
        raise ValueError(f"map_name must be a map name or a list of them, got {map_name!r}")
    for name in maps:
        check_map(name)
    return maps


def _check_players(players) -> None:
    if not players:
        raise ValueError("players is required: [sc2_env.Agent(sc2_env.Race.terran)]")
    players = list(players)
    bots = [p for p in players if isinstance(p, Bot)]
    if bots or len(players) != 1 or not isinstance(players[0], Agent):
        raise ValueError(f"the simulator plays the mini-games with one Agent and no Bot; "
                         f"got {players!r}")
    races = players[0].race if isinstance(players[0].race, (list, tuple)) else [
        players[0].race]
    if not all(r in (Race.terran, Race.random) for r in races):
        raise ValueError(f"race {players[0].race!r}: the mini-games' player is Terran; use "
                         f"Race.terran or Race.random")


def _check_interface(agent_interface_format) -> AgentInterfaceFormat:
    formats = agent_interface_format
    if isinstance(formats, AgentInterfaceFormat):
        return formats
    if isinstance(formats, (list, tuple)) and len(formats) == 1 and isinstance(
            formats[0], AgentInterfaceFormat):
        return formats[0]
    raise ValueError(f"agent_interface_format must be a features.AgentInterfaceFormat (or "
                     f"a list of one, for the one agent), got {formats!r}")
