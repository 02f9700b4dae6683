"""dm_env environments over the simulator, and `make`.

- `SC2Env`: one environment, PySC2's observation layout with PySC2's names
  (`obs.feature_screen.player_relative`, `layout.named`), takes a `FunctionCall` (or an
  unbatched `DenseAction`).
- `MultiAgentSC2Env`: two agents in one game of a ladder map (self-play), as PySC2's
  `SC2Env` with two `Agent`s: steps take one action per agent and return one
  `TimeStep` per agent, each with its own observation and reward.
- `BatchedSC2Env`: `num_envs` environments stepped together in one compiled call, the
  padded layout with a leading batch dimension, takes a batched `DenseAction` or a list
  of `FunctionCall`s. Each environment starts a new episode on the step after its LAST
  timestep (auto-reset). With `num_devices` > 1 the batch is split over that many local
  devices (`devices.over_devices`), each stepping its share at the same time.

Both hold only a state and a key; all game logic is in `Simulator`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import dm_env
import jax
import numpy as np

from sc2jax.environment.engine import computer
from sc2jax.environment.engine.compiled import compiled, compiled_both, simulator
from sc2jax.environment.engine.minigames import MAPS, check_map
from sc2jax.environment.engine.simulator import EnvParams, Simulator
from sc2jax.environment.engine.xla.compilation_cache import use_compilation_cache
from sc2jax.environment.engine.xla.devices import first_devices
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.dense import DenseAction, check_dense_action, to_dense
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, validate_function_call
from sc2jax.environment.interface.layout import named, to_pysc2_layout
from sc2jax.environment.interface.map_names import LADDER_MAP_PATHS
from sc2jax.environment.interface.raw import RawAction, check_raw_action, to_raw_dense


class _Base(dm_env.Environment):

    def __init__(self, sim: Simulator, seed: int | None, ensure_available_actions: bool,
                 game_steps_per_episode: int, batched: bool,
                 devices: tuple[jax.Device, ...] = ()):
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
            raise ValueError(f"seed must be an int or None, got {seed!r}")
        if not isinstance(game_steps_per_episode, int) or game_steps_per_episode < 0:
            raise ValueError(f"game_steps_per_episode must be an int >= 0, got "
                             f"{game_steps_per_episode!r}")
        self.simulator = sim
        self._types = sim.fmt.types
        self._ensure_available = ensure_available_actions
        self._params = EnvParams(game_steps_per_episode=np.int32(game_steps_per_episode))
        seed = np.random.SeedSequence().entropy % (2 ** 31) if seed is None else seed
        self._key = jax.random.PRNGKey(seed)
        self._reset_fn, self._step_fn = compiled(sim, batched, devices)
        self._state = None
        self._available = None
        self._raw = sim.fmt.action_space == "raw"
        self._raw_units = None  # The last padded `raw_units`, which raw calls name rows of.

    def action_spec(self) -> DenseAction | RawAction:
        return self.simulator.action_spec()

    def _raw_action(self, action, batch_shape) -> RawAction:
        """A raw action (a `RawAction`, or `FunctionCall`s of `RAW_FUNCTIONS` naming the
        rows or tags of the last `raw_units`) as checked numpy arrays."""
        grid, rows = self.simulator.renderer.raw_grid.size, self.simulator.fmt.max_units
        if isinstance(action, RawAction):
            return check_raw_action(action, batch_shape, rows, grid)
        calls = [action] if not batch_shape else action
        if not (isinstance(calls, (list, tuple)) and all(isinstance(c, FunctionCall)
                                                        for c in calls)):
            raise TypeError(f"a raw environment's step takes a RawAction or "
                            f"{'a FunctionCall' if not batch_shape else 'FunctionCalls'} of "
                            f"RAW_FUNCTIONS, got {type(action).__name__}")
        if batch_shape and len(calls) != batch_shape[0]:
            raise ValueError(f"expected {batch_shape[0]} FunctionCalls, got {len(calls)}")
        units = np.reshape(self._raw_units, (-1,) + np.shape(self._raw_units)[-2:])
        dense = [to_raw_dense(c, u, grid) for c, u in zip(calls, units)]
        if not batch_shape:
            return dense[0]
        return RawAction(*(np.stack(field) for field in zip(*dense)))

    def _keep(self, timestep):
        """Keeps what the next step checks its action against; returns the timestep."""
        self._available = timestep.observation["available_actions_mask"]
        self._raw_units = timestep.observation.get("raw_units")
        self._last_step_type = np.asarray(timestep.step_type)
        return timestep

    def _check_available(self, function_ids: np.ndarray):
        if not self._ensure_available or self._raw:  # PySC2 checks no raw function.
            return
        if self._available is None:
            raise RuntimeError("call reset() before step()")
        available = np.asarray(self._available).reshape(-1, self._available.shape[-1])
        for index, fid in enumerate(np.asarray(function_ids).reshape(-1)):
            if not available[index, fid]:
                where = f" in environment {index}" if available.shape[0] > 1 else ""
                raise ValueError(
                    f"function {fid}/{FUNCTIONS[int(fid)].name} is not available{where}; "
                    f"available: {np.flatnonzero(available[index]).tolist()}")


class SC2Env(_Base):
    """One mini-game as a `dm_env.Environment` with PySC2's observations and actions.

    Args:
      sim: the simulator.
      seed: RNG seed (None: random). The same seed and actions give the same episodes.
      ensure_available_actions: raise ValueError for an unavailable function (PySC2's
        default); if False the simulator ignores it and reports it in `action_result`.
      game_steps_per_episode: PySC2's episode limit in game loops (0: the map's own).
    """

    def __init__(self, sim: Simulator, seed: int | None = None,
                 ensure_available_actions: bool = True, game_steps_per_episode: int = 0):
        super().__init__(sim, seed, ensure_available_actions, game_steps_per_episode, False)

    def observation_spec(self) -> dict:
        return specs.observation_spec(self.simulator.fmt, padded=False)

    def reset(self) -> dm_env.TimeStep:
        self._key, key = jax.random.split(self._key)
        self._state, timestep = self._reset_fn(key, self._params)
        return self._convert(timestep)

    def step(self, action: FunctionCall | DenseAction) -> dm_env.TimeStep:
        if self._state is None:
            return self.reset()
        dense = self._to_dense(action)
        if int(self._last_step_type) == dm_env.StepType.LAST:
            return self.reset()
        self._check_available(dense.function)
        self._state, timestep = self._step_fn(self._state, dense, self._params)
        return self._convert(timestep)

    def _to_dense(self, action) -> DenseAction | RawAction:
        if self._raw:
            return self._raw_action(action, ())
        if isinstance(action, FunctionCall):
            return to_dense(validate_function_call(action, self._types), self._types)
        if isinstance(action, DenseAction):
            check_dense_action(action, ())
            dense = DenseAction(*(np.asarray(a, np.int32) for a in action))
            _check_dense_ranges(dense, self._types)
            return dense
        raise TypeError(f"SC2Env.step takes a FunctionCall or a DenseAction, got "
                        f"{type(action).__name__}")

    def _convert(self, timestep) -> dm_env.TimeStep:
        timestep = self._keep(jax.device_get(timestep))
        return dm_env.TimeStep(
            step_type=dm_env.StepType(int(timestep.step_type)),
            reward=float(timestep.reward), discount=float(timestep.discount),
            observation=named(to_pysc2_layout(timestep.observation, self.simulator.map_name,
                                              self._raw), self.simulator.fmt))


class MultiAgentSC2Env(SC2Env):
    """Two agents in one game of a two-player (ladder) map, as PySC2's `SC2Env` with two
    `Agent`s: `step((action_1, action_2))` returns (player 1's TimeStep, player 2's),
    each with its own observation (`player_id` 1 and 2) and reward; both actions are
    applied, player 1's first, then the game advances (`Simulator.step_both`).

    Args:
      sim: a two-player map's simulator, without a computer.
      seed, ensure_available_actions, game_steps_per_episode: as for `SC2Env`; each
        agent's action is checked against its own last observation.
    """

    def __init__(self, sim: Simulator, seed: int | None = None,
                 ensure_available_actions: bool = True, game_steps_per_episode: int = 0):
        if sim.game.players != 2 or sim.computer:
            raise ValueError(f"two agents play a two-player map without a computer; got "
                             f"{sim.map_name} ({sim.game.players} player(s)), computer="
                             f"{sim.computer}")
        super().__init__(sim, seed, ensure_available_actions, game_steps_per_episode)
        self._reset_fn, self._step_fn = compiled_both(sim)
        # Each agent's last observation, which its next action is checked against.
        self._seats = [SC2Env(sim, 0, ensure_available_actions) for _ in range(2)]

    def reset(self) -> tuple[dm_env.TimeStep, dm_env.TimeStep]:
        self._key, key = jax.random.split(self._key)
        self._state, timesteps = self._reset_fn(key, self._params)
        return self._convert_both(timesteps)

    def step(self, actions) -> tuple[dm_env.TimeStep, dm_env.TimeStep]:
        if self._state is None:
            return self.reset()
        one = isinstance(actions, (FunctionCall, DenseAction, RawAction))
        if one or not isinstance(actions, (list, tuple)) or len(actions) != 2:
            raise ValueError(f"step takes one action per agent (2 agents), got {actions!r}")
        dense = tuple(seat._to_dense(a) for seat, a in zip(self._seats, actions))
        if int(self._last_step_type) == dm_env.StepType.LAST:
            return self.reset()
        for seat, action in zip(self._seats, dense):
            seat._check_available(action.function)
        self._state, timesteps = self._step_fn(self._state, dense, self._params)
        return self._convert_both(timesteps)

    def _convert_both(self, timesteps):
        first, second = (seat._convert(ts) for seat, ts in zip(self._seats, timesteps))
        self._last_step_type = first.step_type
        return first, second


class BatchedSC2Env(_Base):
    """`num_envs` environments stepped together; padded observations with a batch dim.

    Args:
      sim: the simulator.
      num_envs: the number of environments.
      seed, ensure_available_actions, game_steps_per_episode: as for `SC2Env`.
      num_devices: how many of `jax.local_devices()` to split the environments over, each
        stepping num_envs / num_devices of them (0: all of them). On a CPU, JAX has one
        device unless asked for more before it starts (`devices.use_cpu_cores`). Each
        environment's arithmetic is the same on any count, but the split program is
        compiled for fewer environments and may round differently (`devices`).
    """

    def __init__(self, sim: Simulator, num_envs: int, seed: int | None = None,
                 ensure_available_actions: bool = True, game_steps_per_episode: int = 0,
                 num_devices: int = 1):
        if isinstance(num_envs, bool) or not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive int, got {num_envs!r}")
        devices = _devices_for(num_devices, num_envs)
        super().__init__(sim, seed, ensure_available_actions, game_steps_per_episode, True,
                         devices)
        self.num_envs = num_envs
        self.devices = devices

    def observation_spec(self) -> dict:
        """The spec of one environment's padded observation (without the batch dim)."""
        return specs.observation_spec(self.simulator.fmt, padded=True)

    def reset(self) -> dm_env.TimeStep:
        self._key, key = jax.random.split(self._key)
        keys = jax.random.split(key, self.num_envs)
        self._state, timestep = self._reset_fn(keys, self._params)
        return self._convert(timestep)

    def step(self, action: DenseAction | Sequence[FunctionCall]) -> dm_env.TimeStep:
        if self._state is None:
            return self.reset()
        dense = self._to_dense(action)
        self._check_available_unless_last(dense.function)
        self._state, timestep = self._step_fn(self._state, dense, self._params)
        return self._convert(timestep)

    def _check_available_unless_last(self, function_ids):
        # Environments that just ended reset on this step, so their action is unused.
        ids = np.where(self._last_step_type == dm_env.StepType.LAST, 0, function_ids)
        self._check_available(ids)

    def _to_dense(self, action: Any) -> DenseAction | RawAction:
        if self._raw:
            return self._raw_action(action, (self.num_envs,))
        if isinstance(action, DenseAction):
            check_dense_action(action, (self.num_envs,))
            dense = DenseAction(*(np.asarray(a, np.int32) for a in action))
            _check_dense_ranges(dense, self._types)
            return dense
        if isinstance(action, (list, tuple)) and all(isinstance(a, FunctionCall) for a in action):
            if len(action) != self.num_envs:
                raise ValueError(f"expected {self.num_envs} FunctionCalls, got {len(action)}")
            return to_dense(list(action), self._types)
        raise TypeError(f"BatchedSC2Env.step takes a DenseAction with batch shape "
                        f"({self.num_envs},) or a list of FunctionCalls, got "
                        f"{type(action).__name__}")

    def _convert(self, timestep) -> dm_env.TimeStep:
        return self._keep(jax.device_get(timestep))


def _devices_for(num_devices: int, num_envs: int) -> tuple[jax.Device, ...]:
    """The first `num_devices` local devices (0: all), checked against `num_envs`."""
    local = jax.local_devices()
    if (isinstance(num_devices, bool) or not isinstance(num_devices, int)
            or not 0 <= num_devices <= len(local)):
        raise ValueError(f"num_devices must be an int in 0..{len(local)} (this process has "
                         f"{len(local)} {local[0].platform} devices; 0: all), got "
                         f"{num_devices!r}")
    return first_devices(num_devices or len(local), num_envs)


def _check_dense_ranges(action: DenseAction, types) -> None:
    """Raises ValueError if a dense action's function id or an argument is out of range."""
    fid = np.asarray(action.function)
    if np.any((fid < 0) | (fid >= len(FUNCTIONS))):
        raise ValueError(f"action.function has ids outside 0..{len(FUNCTIONS) - 1}: "
                         f"{np.unique(fid[(fid < 0) | (fid >= len(FUNCTIONS))]).tolist()}")
    for t, values in zip(types, action.arguments):
        values = np.asarray(values)
        if t.is_point:
            bad = (values < 0) | (values >= np.asarray(t.sizes))
        else:
            bad = (values < 0) | (values >= t.sizes[0])
        if np.any(bad):
            allowed = (f"x in 0..{t.sizes[0] - 1}, y in 0..{t.sizes[1] - 1}" if t.is_point
                       else f"0..{t.sizes[0] - 1}")
            raise ValueError(f"action.{t.name} has values outside the allowed range "
                             f"{allowed}: {np.unique(values[bad]).tolist()[:8]}")


LADDER_GAME_STEPS = 16 * 60 * 30
"""PySC2's episode limit on ladder maps: 30 game minutes, in game loops."""


def make(map_name: str, screen_size: specs.Size = 64, minimap_size: specs.Size = 64,
         step_mul: int = 8, num_envs: int | None = None, seed: int | None = None, *,
         screen_features: Sequence[str] | None = None,
         minimap_features: Sequence[str] | None = None, use_feature_units: bool = False,
         use_raw_units: bool = False, max_units: int = 64, score_index: int = 0,
         score_multiplier: float = 1.0, discount: float = 1.0,
         ensure_available_actions: bool = True, game_steps_per_episode: int = 0,
         allow_cheating_layers: bool = False, backend: str = "simulator",
         sc2path: str | None = None, bot: Any = None,
         num_devices: int = 1, use_slot_sizes: bool = True, action_space: str = "features",
         raw_resolution: specs.Size | None = None,
         num_slots: int | None = None, num_agents: int = 1) -> dm_env.Environment:
    """Creates an environment by map name: the simulator's, or the real game's.

    Args:
      map_name: a mini-game, e.g. "MoveToBeacon", or a ladder map of the simulator's
        melee game (`map_names.LADDER_MAPS`, e.g. "Acropolis").
      screen_size, minimap_size: resolutions, an int or (x, y), each in 16..256.
      step_mul: game loops per agent step.
      num_envs: None for one `SC2Env`; N for a `BatchedSC2Env` of N environments.
      seed: RNG seed.
      screen_features, minimap_features: layer names to render (None: all).
      use_feature_units, use_raw_units: add the unit lists.
      max_units: rows of the padded unit lists.
      score_index, score_multiplier, discount: the reward and discount (see `Simulator`).
      ensure_available_actions: raise for unavailable functions (else they are no-ops).
      game_steps_per_episode: PySC2's truncation limit in game loops (0: none).
      allow_cheating_layers: fill the minimap `unit_type` layer.
      backend: "simulator" (the embedded default) or "sc2": StarCraft II itself, launched
        from `sc2path` (default `$SC2PATH`) and driven over its API by a
        `game_env.GameEnv` with the same observations and actions. The game may be any
        map it knows (a mini-game name, or a path under its Maps folder).
      sc2path: the game's install folder (backend "sc2").
      bot: a `game_env.Bot` opponent on a ladder map. With the simulator, a Terran
        computer of build "random" at a difficulty it plays (`computer.LEVELS`:
        very_easy, easy, medium or hard); None leaves the other player idle. On maps
        other than the mini-games the reward defaults to the outcome (score_index -1)
        and episodes to PySC2's 30 game minutes (`LADDER_GAME_STEPS`), a tie.
      num_devices: split a `BatchedSC2Env`'s environments over this many local devices
        (0: all; see `BatchedSC2Env`). Only with num_envs and the simulator.
      use_slot_sizes: the simulator's (`Simulator`): True (the default) runs the economy
        and wave maps on the unit slots in use; False on every slot, the same game, slower
        to run but quicker to compile (one copy of the game loop, not one per slot size).
      action_space: "features" (`FUNCTIONS`) or "raw" (`RAW_FUNCTIONS`, PySC2's
        `ActionSpace.RAW`: needs use_raw_units; steps take `FunctionCall`s of raw
        functions, whose unit tags may be rows of the last `raw_units`, or a
        `raw.RawAction`). The simulator only, for now.
      raw_resolution: the raw grid of `raw_units` and of the raw actions' `world` point
        (None: the map's size, PySC2's default).
      num_slots: on a ladder map of the simulator, its unit slots (`Simulator.num_slots`;
        None: enough for two players at 200 supply).
      num_agents: 1, or 2 for a `MultiAgentSC2Env`: two agents in one game of a ladder
        map (self-play; num_envs None, no bot, the simulator).

    Returns:
      An `SC2Env` (num_envs None), a `MultiAgentSC2Env` (num_agents 2), a
      `BatchedSC2Env`, or for backend "sc2" a `game_env.GameEnv`.

    The simulator's programs go to JAX's persistent compilation cache
    (`engine.xla.compilation_cache`; `SC2JAX_COMPILATION_CACHE=0` turns it off), so a
    later process skips their compilation.

    Raises:
      ValueError: for an unknown map or a bad setting, before anything is compiled.
    """
    if num_devices != 1 and (num_envs is None or backend != "simulator"):
        raise ValueError(f"num_devices={num_devices!r} splits a batch of simulator "
                         f"environments; it needs num_envs and backend='simulator' (got "
                         f"num_envs={num_envs!r}, backend={backend!r})")
    if num_agents not in (1, 2) or isinstance(num_agents, bool):
        raise ValueError(f"num_agents must be 1 or 2, got {num_agents!r}")
    if num_agents == 2 and (num_envs is not None or bot is not None or backend != "simulator"
                            or map_name in MAPS):
        raise ValueError(f"num_agents=2 plays two agents in one game of a ladder map on the "
                         f"simulator, without num_envs or a bot; got map_name={map_name!r}, "
                         f"num_envs={num_envs!r}, bot={bot!r}, backend={backend!r}")
    if backend == "sc2":
        if action_space != "features" or raw_resolution is not None:
            raise ValueError(f"backend 'sc2' takes the feature action space and the "
                             f"default raw resolution for now; got action_space="
                             f"{action_space!r}, raw_resolution={raw_resolution!r}")
        return _make_game(map_name, screen_size, minimap_size, step_mul, num_envs, seed,
                          screen_features, minimap_features, use_feature_units, use_raw_units,
                          max_units, score_index, score_multiplier, discount,
                          ensure_available_actions, game_steps_per_episode, sc2path, bot)
    if backend != "simulator":
        raise ValueError(f"backend {backend!r} is not allowed; expected 'simulator' or 'sc2'")
    if sc2path is not None:
        raise ValueError("sc2path applies to backend='sc2' only")
    check_map(map_name)
    computer = simulator_computer(bot, map_name)
    if not score_index and map_name not in MAPS:
        score_index = default_score_index(map_name)  # PySC2's on ladder maps: the outcome.
    use_compilation_cache()
    fmt = specs.ObservationFormat(
        screen_size=screen_size, minimap_size=minimap_size,
        screen_features=None if screen_features is None else tuple(screen_features),
        minimap_features=None if minimap_features is None else tuple(minimap_features),
        use_feature_units=use_feature_units, use_raw_units=use_raw_units, max_units=max_units,
        raw_resolution=raw_resolution, action_space=action_space)
    sim = simulator(map_name, fmt, step_mul, score_index, float(score_multiplier),
                    float(discount), allow_cheating_layers, use_slot_sizes, num_slots, computer)
    if num_agents == 2:
        return MultiAgentSC2Env(sim, seed, ensure_available_actions, game_steps_per_episode)
    if num_envs is None:
        return SC2Env(sim, seed, ensure_available_actions, game_steps_per_episode)
    return BatchedSC2Env(sim, num_envs, seed, ensure_available_actions, game_steps_per_episode,
                         num_devices)


def default_score_index(map_name: str) -> int:
    """PySC2's default reward on a map: the mini-games' score (score_index 0), the
    outcome (-1) on any other map."""
    return 0 if map_name in MAPS else -1


def simulator_computer(bot, map_name: str) -> int:
    """The `Difficulty` of the simulator's computer a `game_env.Bot` asks for (0: none).

    Raises:
      ValueError: for a bot on a mini-game, or one the simulator does not play.
    """
    if bot is None:
        return 0
    if map_name in MAPS:
        raise ValueError(f"bot plays the other player of a ladder map; {map_name} is a "
                         "mini-game")
    return int(computer.opponent(getattr(bot, "race", None), getattr(bot, "difficulty", None),
                                 getattr(bot, "build", None)))


def _make_game(map_name, screen_size, minimap_size, step_mul, num_envs, seed, screen_features,
               minimap_features, use_feature_units, use_raw_units, max_units, score_index,
               score_multiplier, discount, ensure_available_actions, game_steps_per_episode,
               sc2path, bot):
    """`make` for the real game (backend "sc2")."""
    # Imported here: game_env imports this module.
    from sc2jax.environment.sc2api.game_env import GameEnv
    from sc2jax.environment.sc2api.launcher import launch

    if num_envs is not None:
        raise ValueError(f"backend 'sc2' runs one game per environment; got num_envs="
                         f"{num_envs!r} (use num_envs=None, and one process per game)")
    if not isinstance(map_name, str) or not map_name:
        raise ValueError(f"map_name must be a non-empty str, got {map_name!r}")
    if map_name in MAPS:
        map_path = f"mini_games/{map_name}.SC2Map"
    else:  # A ladder map: PySC2's 30-minute limit, which ends the game in a tie.
        map_path = LADDER_MAP_PATHS.get(map_name) or (
            map_name if map_name.endswith(".SC2Map") else f"{map_name}.SC2Map")
        game_steps_per_episode = game_steps_per_episode or LADDER_GAME_STEPS
    return GameEnv(lambda: launch(sc2path).controller, map_name, map_path=map_path,
                   screen_size=screen_size, minimap_size=minimap_size,
                   screen_features=screen_features, minimap_features=minimap_features,
                   use_feature_units=use_feature_units, use_raw_units=use_raw_units,
                   max_units=max_units, bot=bot, step_mul=step_mul,
                   game_steps_per_episode=game_steps_per_episode,
                   # On other maps the default is PySC2's: the outcome.
                   score_index=score_index if map_name in MAPS or score_index
                   else default_score_index(map_name),
                   score_multiplier=score_multiplier, discount=discount,
                   ensure_available_actions=ensure_available_actions, random_seed=seed)
