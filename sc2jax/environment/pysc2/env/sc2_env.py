"""PySC2's `pysc2.env.sc2_env`: `SC2Env` with PySC2 v4's constructor, over the simulator.

    env = sc2_env.SC2Env(
        map_name="MoveToBeacon", players=[sc2_env.Agent(sc2_env.Race.terran)],
        agent_interface_format=features.AgentInterfaceFormat(
            feature_dimensions=features.Dimensions(screen=84, minimap=64)),
        step_mul=8)
    timesteps = env.reset()                  # a tuple: one TimeStep per agent
    timesteps = env.step([actions.FUNCTIONS.select_army("select")])

It plays the mini-games with one agent, as Terran, and the simulator's ladder maps
(Terran against Terran) with one agent (against an idle player, or a
`Bot(Race.terran, difficulty)`) or two (self-play). Agents act through the feature
layers or, with `ActionSpace.RAW`, through `RAW_FUNCTIONS`. The episodes are those of
`sc2jax.environment.make` with the same settings (the same seed gives the same
episodes); the observations are PySC2's layout with its names.
"""

from __future__ import annotations

import collections
import random
from collections.abc import Sequence

import dm_env

from sc2jax.environment.engine.minigames import MAPS, check_map
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.arguments import MAX_RAW_UNIT_TAGS, RAW_TYPES
from sc2jax.environment.interface.functions import (
    FUNCTIONS,
    RAW_FUNCTIONS,
    FunctionCall,
    Functions,
)
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
from sc2jax.environment.sc2api.game_env import Bot as GameBot

__all__ = ["ActionSpace", "Agent", "AgentInterfaceFormat", "Bot", "BotBuild", "Difficulty",
           "Dimensions", "Race", "SC2Env", "StepType", "TimeStep",
           "parse_agent_interface_format"]


class Agent(collections.namedtuple("Agent", ["race", "name"])):
    """A player the agent controls: its race (or a list to pick from) and name."""

    def __new__(cls, race, name=None):
        return super().__new__(cls, race, name or "<unknown>")


class Bot(collections.namedtuple("Bot", ["race", "difficulty", "build"])):
    """A built-in AI player: on the simulator's ladder maps, its computer (Terran, of
    build random, at `computer.LEVELS`' difficulties); the mini-games have none."""

    def __new__(cls, race, difficulty, build=None):
        return super().__new__(cls, race, difficulty, build or BotBuild.random)


class SC2Env:
    """A game on the simulator, with PySC2 v4's constructor and returns.

    Args (keyword only, as PySC2's; see its documentation):
      map_name: a map name (a mini-game or a ladder map), or a list of them (one is
        picked at each reset).
      players: one `Agent` of race terran or random (the simulator's player is
        Terran); on ladder maps also an `Agent` and a `Bot(Race.terran, difficulty)`, or
        two `Agent`s (self-play: steps take and return one per agent).
      agent_interface_format: an `AgentInterfaceFormat`, or a list of one per agent
        (the same for both). Raw agents' `raw_units` list up to 64 units on the
        mini-games and `MAX_RAW_UNIT_TAGS` (512) on ladder maps.
      discount: the discount of MID steps (and of LAST steps at the time limit).
      discount_zero_after_timeout: a LAST step at the time limit has discount 0.
      step_mul: game loops per agent step (None: 8).
      game_steps_per_episode: the episode's limit in game loops (None or 0: the map's).
      score_index: the reward's `score_cumulative` entry (None: the map's: 0, the
        mini-game score, on mini-games; -1, the outcome, on ladder maps).
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
        self._num_agents, bot = _check_players(players, self._maps)
        self._interface = interface = _check_interface(agent_interface_format,
                                                       self._num_agents)
        dims = interface.feature_dimensions
        ladder = any(name not in MAPS for name in self._maps)
        self._fmt = specs.ObservationFormat(
            screen_size=dims.screen, minimap_size=dims.minimap,
            use_feature_units=interface.use_feature_units,
            use_raw_units=interface.use_raw_units,
            max_units=MAX_RAW_UNIT_TAGS if ladder and interface.use_raw_units else 64,
            raw_resolution=interface.raw_resolution,
            action_space="raw" if interface.raw else "features")
        self._settings = dict(
            screen_size=dims.screen, minimap_size=dims.minimap,
            step_mul=8 if step_mul is None else step_mul,
            use_feature_units=interface.use_feature_units,
            use_raw_units=interface.use_raw_units, max_units=self._fmt.max_units,
            raw_resolution=interface.raw_resolution, action_space=self._fmt.action_space,
            num_agents=self._num_agents, bot=bot,
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
        return (spec,) * self._num_agents

    def action_spec(self) -> tuple[actions.ValidActions, ...]:
        """One `ValidActions` per agent: the argument types at the agent's resolutions,
        and every function with its arguments of those types (the raw ones, with the
        raw grid's `world` and `max_selected_units` unit tags, for raw agents)."""
        if self._interface.raw:
            env = self._envs.get(self._maps[0]) or self._make(self._maps[0])
            types = RAW_TYPES._replace(
                world=RAW_TYPES.world._replace(sizes=env.simulator.renderer.raw_grid.size),
                unit_tags=RAW_TYPES.unit_tags._replace(
                    sizes=(self._interface.max_selected_units,)))
            table = RAW_FUNCTIONS
        else:
            types, table = self._fmt.types, FUNCTIONS
        functions = Functions([f._replace(args=tuple(types[a.id] for a in f.args))
                               for f in table])
        return (actions.ValidActions(types, functions),) * self._num_agents

    def reset(self) -> tuple[TimeStep, ...]:
        """Starts an episode (on a map picked at random, if several)."""
        name = self._rng.choice(self._maps)
        if name not in self._envs:
            self._envs[name] = self._make(name)
        self._env = self._envs[name]
        return self._keep(self._env.reset())

    def step(self, actions: Sequence[FunctionCall] | FunctionCall,
             step_mul: int | None = None) -> tuple[TimeStep, ...]:
        """Applies one action per agent (a list of one `FunctionCall` each) and advances
        `step_mul` game loops. After a LAST timestep, starts a new episode instead.

        Raises:
          ValueError: not one action per agent, an unavailable function (with
            `ensure_available_actions`), or a `step_mul` other than the environment's.
        """
        if step_mul is not None and step_mul != self._settings["step_mul"]:
            raise ValueError(f"step_mul={step_mul!r} per step is not supported; this "
                             f"environment steps {self._settings['step_mul']} game loops")
        if isinstance(actions, FunctionCall):
            actions = [actions]
        if len(actions) != self._num_agents:
            raise ValueError(f"step takes one action per agent ({self._num_agents} "
                             f"agent(s)), got {len(actions)}")
        if self._last is None or self._last[0].last():
            return self.reset()
        return self._keep(self._env.step(actions[0] if self._num_agents == 1 else actions))

    def _keep(self, timesteps) -> tuple[TimeStep, ...]:
        timesteps = (timesteps,) if self._num_agents == 1 else tuple(timesteps)
        if self._discount_zero_after_timeout and timesteps[0].last():
            timesteps = tuple(t._replace(discount=0.0) for t in timesteps)
        self._last = timesteps
        return timesteps

    def close(self) -> None:
        self._envs, self._env, self._last = {}, None, None

    def __enter__(self) -> SC2Env:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # Internals.

    def _make(self, map_name: str) -> dm_env.Environment:
        seed = None if self._seed is None else self._seed + self._maps.index(map_name)
        return make(map_name, seed=seed, **self._settings)  # Ladder maps: score_index -1.


def _check_maps(map_name) -> list[str]:
    if map_name is None:
        raise ValueError("map_name is required: a mini-game name or a list of them")
    maps = [map_name] if isinstance(map_name, str) else list(map_name)
    if not maps or not all(isinstance(m, str) for m in maps):
        raise ValueError(f"map_name must be a map name or a list of them, got {map_name!r}")
    for name in maps:
        check_map(name)
    return maps


def _check_players(players, maps) -> tuple[int, GameBot | None]:
    """(the number of agents, the other player's computer or None)."""
    if not players:
        raise ValueError("players is required: [sc2_env.Agent(sc2_env.Race.terran)]")
    players = list(players)
    agents = [p for p in players if isinstance(p, Agent)]
    bots = [p for p in players if isinstance(p, Bot)]
    ladder = all(name not in MAPS for name in maps)
    shapes = (1, 0), (2, 0), (1, 1)
    if (len(agents), len(bots)) not in shapes[:3 if ladder else 1] or len(players) != len(
            agents) + len(bots) or not isinstance(players[0], Agent):
        raise ValueError(f"the simulator plays the mini-games with one Agent and no Bot, "
                         f"and its ladder maps with one Agent, two, or an Agent then a Bot; "
                         f"got {players!r} on {maps}")
    for player in players:
        races = player.race if isinstance(player.race, (list, tuple)) else [player.race]
        if not all(r in (Race.terran, Race.random) for r in races):
            raise ValueError(f"race {player.race!r}: the simulator's players are Terran; "
                             f"use Race.terran or Race.random")
    if not bots:
        return len(agents), None
    bot = bots[0]
    return 1, GameBot("terran", int(Difficulty(bot.difficulty)), BotBuild(bot.build).name)


def _check_interface(agent_interface_format, num_agents: int) -> AgentInterfaceFormat:
    formats = agent_interface_format
    if isinstance(formats, AgentInterfaceFormat):
        return formats
    if isinstance(formats, (list, tuple)) and len(formats) == num_agents and all(
            f == formats[0] and isinstance(f, AgentInterfaceFormat) for f in formats):
        return formats[0]
    raise ValueError(f"agent_interface_format must be a features.AgentInterfaceFormat (or "
                     f"a list of one per agent, {num_agents}, all the same), got {formats!r}")
