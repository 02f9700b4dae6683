"""The StarCraft II API answered by the simulator: one game, as one game process has.

`GameService.handle(request) -> response` takes `sc2api.Request` protos and returns
`sc2api.Response` protos; the websocket server (`server.py`) only moves bytes. The flow
is the real game's (reference/pysc2_facts.md §6):

    ping → create_game (the map by name: a mini-game with one Participant, or a ladder
    map with one Participant, and a Computer that the simulator's built-in AI plays)
    → join_game (the feature-layer resolutions) → [action → step → observation]*
    → save_replay → restart_game → ... → leave_game → quit
    ping → replay_info → start_replay → [step → observation]* → leave_game → ...

Status goes launched → init_game → in_game → ended (when the episode ends; the
observation then carries a `player_result`) → launched (after leave) → quit; a replay
goes launched → in_replay → ended → launched.

A replay (`save_replay`) is the episode's key and the calls applied at each step
(`replays.py`); `start_replay` plays it again through the same compiled programs, so its
observations are the game's bit for bit, and each observation's `actions` are the calls
the player made in the step before it, with their arguments, as the real game reports a
replay's actions.

A step runs exactly as `Simulator.step` does for the same actions, keys and step_mul, so
a client sees the in-process simulator's episodes bit for bit: `random_seed` seeds the
episode keys as `SC2Env(seed=...)` does, each game start (join or restart) draws the next
key. The programs are compiled once per map and format, for every step count, and a
bounded number are kept (`programs.py`).
Anything the simulator does not do is answered with `Response.error`.
"""

from __future__ import annotations

import logging
import pathlib

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.engine import computer
from sc2jax.environment.engine.minigames import MAPS, get_map
from sc2jax.environment.engine.rules.state import Outcome
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType, game_name
from sc2jax.environment.engine.simulator import EnvParams
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.dense import to_dense
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, validate_function_call
from sc2jax.environment.interface.map_names import LADDER_MAPS, MINI_GAMES, map_of_path
from sc2jax.environment.interface.observation_tables import TERRAN
from sc2jax.environment.interface.players import BotBuild
from sc2jax.environment.sc2api import proto_actions, proto_observation
from sc2jax.environment.sc2api.controller import RequestError
from sc2jax.environment.sc2api.protos import sc2api
from sc2jax.environment.server.programs import Programs, programs
from sc2jax.environment.server.replays import Replay

GAME_VERSION = "4.10.0"
BASE_BUILD = 75689
MAX_STEP_COUNT = 10_000
"""The most game loops one `RequestStep` may run here."""
MAX_ACTIONS_PER_STEP = 64
"""The most actions waiting for one step (PySC2 sends one per agent step; a step's work
grows with them, under the server's lock)."""

SC2_NAMES = {
    UnitType.ZERGLING: "Zergling", UnitType.ROACH: "Roach", UnitType.BANELING: "Baneling",
    UnitType.BEACON: "Beacon_Terran", UnitType.MINERAL_SHARD: "NaturalMinerals",
    UnitType.MINERAL_FIELD: "MineralField", UnitType.VESPENE_GEYSER: "VespeneGeyser",
    **{t: game_name(t) for t in UnitType if game_name(t) is not None},
}
"""The game's names of the simulator's unit types (`data` replies)."""

SUPPORTED = ("ping", "create_game", "join_game", "restart_game", "leave_game", "quit",
             "game_info", "data", "action", "step", "observation", "save_replay",
             "replay_info", "start_replay")
"""The requests the simulator answers; the others get `Response.error`."""

log = logging.getLogger(__name__)
_PARAMS = EnvParams(game_steps_per_episode=np.int32(0))  # The map's own timer ends games.
_STATUS = sc2api.Status
_RESULT = sc2api.ActionResult


def _computer_of(player_setup, map_name: str) -> int:
    """The `Difficulty` of the computer a game's players ask for (0: none).

    Raises:
      ValueError: for players the simulator does not play, naming what it does.
    """
    kinds = [sc2api.PlayerType.Name(p.type) for p in player_setup]
    allowed = [["Participant"]] + ([["Participant", "Computer"]] if map_name in LADDER_MAPS
                                   else [])
    if kinds not in allowed:
        raise ValueError(f"the simulator plays the mini-games with one Participant, and its "
                         f"ladder maps with one Participant and at most one Computer after "
                         f"it; got {kinds} on {map_name}")
    if len(kinds) == 1:
        return 0
    bot = player_setup[1]
    build = "random" if bot.ai_build == 0 else BotBuild(bot.ai_build).name  # 0: unset.
    return int(computer.opponent(sc2api.Race.Name(bot.race).lower(), bot.difficulty, build))


def _check_replay(replay: Replay) -> None:
    """Raises ValueError for a replay this server would not have written: another map,
    a bad key or resolution, a step of more than `MAX_STEP_COUNT` loops or
    `MAX_ACTIONS_PER_STEP` calls, or a call outside its resolutions."""
    if replay.map_name not in MAPS:
        raise ValueError(f"the replay's map {replay.map_name!r} is not a mini-game of the "
                         f"simulator; it has {sorted(MAPS)}")
    if len(replay.key) != 2 or not all(0 <= k < 2 ** 32 for k in replay.key):
        raise ValueError(f"the replay's key {replay.key!r} is not two 32-bit words")
    types = specs.ObservationFormat(replay.screen_size, replay.minimap_size).types
    for n, (loops, calls) in enumerate(replay.steps):
        if not 1 <= loops <= MAX_STEP_COUNT or len(calls) > MAX_ACTIONS_PER_STEP:
            raise ValueError(f"the replay's step {n} runs {loops} loops with {len(calls)} "
                             f"calls; allowed: 1..{MAX_STEP_COUNT} loops, at most "
                             f"{MAX_ACTIONS_PER_STEP} calls")
        for call in calls:
            validate_function_call(call, types)


class GameService:
    """One simulated game process answering SC2 API requests.

    Args:
      melee_slots: the unit slots of ladder maps' games (`Simulator.num_slots`; None:
        enough for two players at 200 supply).
    """

    def __init__(self, melee_slots: int | None = None):
        self.status = _STATUS.launched
        self._melee_slots = melee_slots
        self._computer = 0
        self._map_name: str | None = None
        self._map_path = ""
        self._seed_key = None
        self._options = None
        self._fmt: specs.ObservationFormat | None = None
        self._programs: Programs | None = None
        self._state = None
        self._last_observation = None
        self._pending: list[FunctionCall] = []
        self._episode_key = None
        self._steps: list[tuple[int, list[FunctionCall]]] = []
        """The episode's steps so far: (game loops, the calls applied)."""
        self._replay: Replay | None = None
        self._replay_next = 0
        self._replayed: list[FunctionCall] = []
        """In a replay: the calls of the steps since the last observation."""

    # Dispatch.

    def handle(self, request) -> object:
        """The `sc2api.Response` to one `sc2api.Request` (errors included, never raises)."""
        response = sc2api.Response()
        if request.HasField("id"):
            response.id = request.id
        kind = request.WhichOneof("request")
        try:
            handler = getattr(self, f"_{kind}") if kind in SUPPORTED else None
            if handler is None:
                raise RequestError(kind, [f"request {kind or '(empty)'!r} is not supported "
                                         f"by the sc2jax simulator"])
            getattr(response, kind).SetInParent()
            handler(getattr(request, kind), response)
        except RequestError as e:
            response.error.extend(e.errors)
        except Exception as e:  # A bad request must never take the game down.
            log.exception("%s failed", kind)
            response.error.append(f"{kind} failed inside the simulator: {type(e).__name__}: {e}")
        response.status = self.status
        return response

    def abandon(self) -> None:
        """Leaves the game or replay, if one runs (its owner has gone)."""
        if self.status in (_STATUS.init_game, _STATUS.in_game, _STATUS.in_replay,
                           _STATUS.ended):
            self._state, self._replay, self.status = None, None, _STATUS.launched
            self._programs = None

    def _require(self, kind: str, *statuses) -> None:
        if self.status not in statuses:
            allowed = ", ".join(_STATUS.Name(s) for s in statuses)
            raise RequestError(kind, [f"{kind} needs status {allowed}; the status is "
                                     f"{_STATUS.Name(self.status)}"])

    # Requests.

    def _ping(self, request, response) -> None:
        del request
        ping = response.ping
        ping.game_version, ping.base_build, ping.data_build = GAME_VERSION, BASE_BUILD, BASE_BUILD

    def _create_game(self, request, response) -> None:
        self._require("create_game", _STATUS.launched)
        error = response.create_game
        if request.HasField("local_map"):
            self._map_path = request.local_map.map_path
            name = map_of_path(self._map_path)
        elif request.HasField("battlenet_map_name"):
            name = map_of_path(request.battlenet_map_name)
        else:
            error.error = error.Error.Value("MissingMap")
            error.error_details = "create_game needs local_map or battlenet_map_name"
            return
        if name is None:
            error.error = error.Error.Value("InvalidMapPath")
            given = request.local_map.map_path or request.battlenet_map_name
            error.error_details = (f"map {given!r} is not a map of the simulator; it has "
                                   f"the mini-games {sorted(MINI_GAMES)} and the ladder "
                                   f"maps {sorted(LADDER_MAPS)}")
            return
        try:
            computer = _computer_of(request.player_setup, name)
        except ValueError as e:
            error.error = error.Error.Value("InvalidPlayerSetup")
            error.error_details = str(e)
            return
        seed = (request.random_seed if request.HasField("random_seed")
                else int(np.random.SeedSequence().entropy % (2 ** 31)))
        self._map_name, self._computer = name, computer
        self._seed_key = jax.random.PRNGKey(seed)
        self.status = _STATUS.init_game

    def _join_game(self, request, response) -> None:
        self._require("join_game", _STATUS.init_game)
        options = request.options
        layers = options.feature_layer
        if not request.HasField("options") or not options.HasField("feature_layer"):
            response.join_game.error = response.join_game.Error.Value("MissingOptions")
            response.join_game.error_details = ("the simulator needs options.feature_layer "
                                                "(its observations are feature layers)")
            return
        try:
            if layers.HasField("width") and not abs(layers.width - 24) <= 1e-6:  # NaN too
                raise ValueError(f"feature_layer.width {layers.width} is not supported; the "
                                 f"simulator's camera is 24 world units wide")
            # With `raw`, the format of a PySC2 client that asks for the unit lists, so
            # the steps are that `SC2Env`'s program too (the rows themselves are built
            # by the client from `raw_data.units`).
            fmt = specs.ObservationFormat(
                screen_size=(layers.resolution.x, layers.resolution.y),
                minimap_size=(layers.minimap_resolution.x, layers.minimap_resolution.y),
                use_feature_units=options.raw, use_raw_units=options.raw)
        except ValueError as e:
            response.join_game.error = response.join_game.Error.Value("FeatureUnsupported")
            response.join_game.error_details = str(e)
            return
        self._options, self._fmt = options, fmt
        response.join_game.player_id = 1
        self._start()

    def _restart_game(self, request, response) -> None:
        del request, response
        self._require("restart_game", _STATUS.in_game, _STATUS.ended)
        self._start()

    def _leave_game(self, request, response) -> None:
        del request, response
        self._require("leave_game", _STATUS.in_game, _STATUS.in_replay, _STATUS.ended)
        self.abandon()

    def _quit(self, request, response) -> None:
        del request, response
        self._state, self._programs, self.status = None, None, _STATUS.quit

    def _game_info(self, request, response) -> None:
        del request
        self._require("game_info", _STATUS.in_game, _STATUS.in_replay, _STATUS.ended)
        info = response.game_info
        info.map_name, info.local_map_path = self._map_name, self._map_path
        info.player_info.add(player_id=1, type=sc2api.PlayerType.Value("Participant"),
                             race_requested=TERRAN, race_actual=TERRAN)
        if self._computer:
            info.player_info.add(player_id=2, type=sc2api.PlayerType.Value("Computer"),
                                 race_requested=TERRAN, race_actual=TERRAN,
                                 difficulty=self._computer)
        geometry = get_map(self._map_name).geometry
        raw = info.start_raw
        raw.map_size.x, raw.map_size.y = geometry.size
        x0, y0, x1, y1 = (int(v) for v in geometry.playable)
        raw.playable_area.p0.x, raw.playable_area.p0.y = x0, y0
        raw.playable_area.p1.x, raw.playable_area.p1.y = x1, y1
        # The grids are bottom row first on the wire; the geometry keeps the top first.
        raw.pathing_grid.CopyFrom(proto_observation.encode_image(geometry.pathable[::-1], 2))
        raw.placement_grid.CopyFrom(proto_observation.encode_image(geometry.buildable[::-1], 2))
        raw.terrain_height.CopyFrom(proto_observation.encode_image(geometry.height_map[::-1],
                                                                   256))
        info.options.CopyFrom(self._options)

    def _data(self, request, response) -> None:
        self._require("data", _STATUS.in_game, _STATUS.in_replay, _STATUS.ended)
        if not request.unit_type_id:
            return
        d = UNIT_DATA
        for t, name in SC2_NAMES.items():
            response.data.units.add(
                unit_id=int(d.sc2_id[t]), name=name, available=True,
                mineral_cost=int(d.mineral_cost[t]), vespene_cost=int(d.vespene_cost[t]),
                food_required=float(d.food[t]),
                food_provided=float(d.supply[t]), build_time=float(d.build_time[t]),
                sight_range=float(d.sight[t]), armor=float(d.armor[t]),
                movement_speed=float(d.speed[t]) * 16,
                has_minerals=t == UnitType.MINERAL_FIELD,
                has_vespene=t in (UnitType.VESPENE_GEYSER, UnitType.REFINERY))

    def _action(self, request, response) -> None:
        self._require("action", _STATUS.in_game, _STATUS.ended)
        if len(self._pending) + len(request.actions) > MAX_ACTIONS_PER_STEP:
            raise RequestError("action", [
                f"{len(request.actions)} actions with {len(self._pending)} already waiting "
                f"for the next step; at most {MAX_ACTIONS_PER_STEP} per step"])
        for action in request.actions:
            call = proto_actions.from_proto(action)
            if self.status != _STATUS.in_game:
                code = _RESULT.Value("Error")  # The game has ended: nothing is done.
            elif call.function == FUNCTIONS.no_op.id:
                # Raw, render or chat actions, or an ability PySC2 has no function for.
                code = _RESULT.Value("NotSupported")
            else:
                try:
                    self._pending.append(validate_function_call(call, self._fmt.types))
                    code = _RESULT.Value("Success")
                except ValueError:
                    code = _RESULT.Value("Error")
            response.action.result.append(code)

    def _step(self, request, response) -> None:
        self._require("step", _STATUS.in_game, _STATUS.in_replay, _STATUS.ended)
        count = request.count if request.HasField("count") else 1
        if not 1 <= count <= MAX_STEP_COUNT:
            raise RequestError("step", [f"step count {count} is outside 1..{MAX_STEP_COUNT}"])
        if self.status == _STATUS.in_game:
            self._steps.append((count, self._pending))
            self._play(count, self._pending)
            self._pending = []
        elif self.status == _STATUS.in_replay:
            # Whole recorded steps, until `count` loops have passed or the replay ends.
            target = int(self._state.game_loop) + count
            steps = self._replay.steps
            while self._replay_next < len(steps) and int(self._state.game_loop) < target:
                loops, calls = steps[self._replay_next]
                self._replay_next += 1
                self._play(loops, calls)
                self._replayed.extend(calls)
            if self._replay_next == len(steps):
                self.status = _STATUS.ended
        response.step.simulation_loop = int(self._state.game_loop)

    def _play(self, count: int, calls: list[FunctionCall]) -> None:
        """Applies `calls` (none: no_op) and runs `count` game loops."""
        calls = calls or [FunctionCall(FUNCTIONS.no_op.id, [])]
        run = self._programs
        for call in calls[:-1]:
            self._state = run.act(self._state, to_dense(call, self._fmt.types))
        # While the game runs, `Simulator.step` is `advance` then `observe`.
        self._state, timestep = run.step(self._state, to_dense(calls[-1], self._fmt.types),
                                         _PARAMS, np.int32(count))
        self._last_observation = timestep.observation
        if int(self._state.outcome) != Outcome.RUNNING:
            self.status = _STATUS.ended

    def _observation(self, request, response) -> None:
        del request
        self._require("observation", _STATUS.in_game, _STATUS.in_replay, _STATUS.ended)
        obs = jax.device_get(self._last_observation)
        outcome = int(self._state.outcome)
        result = None if outcome == Outcome.RUNNING else outcome  # Result values match.
        response.observation.CopyFrom(proto_observation.encode(obs, self._fmt, result=result))
        if self._replay is not None:
            del response.observation.actions[:]
            response.observation.actions.extend(
                proto_actions.to_proto(call) for call in self._replayed)
            self._replayed = []
        raw_data = response.observation.observation.raw_data
        raw_data.player.camera.x = float(self._state.camera[0])
        raw_data.player.camera.y = float(self._state.camera[1])
        if self._options.raw:
            units = jax.device_get(self._programs.units(self._state))
            proto_observation.encode_units(units, raw_data)

    # Internals.

    def _start(self) -> None:
        """Starts an episode with the next key, as `SC2Env.reset` does."""
        self._seed_key, key = jax.random.split(self._seed_key)
        self._reset(key)
        self.status = _STATUS.in_game

    def _reset(self, key) -> None:
        self._episode_key = key
        ladder = self._map_name not in MINI_GAMES
        self._programs = programs(self._map_name, self._fmt, self._computer,
                                  self._melee_slots if ladder else None)
        self._state, timestep = self._programs.reset(key, _PARAMS)
        self._last_observation = timestep.observation
        self._pending, self._steps = [], []

    # Replays.

    def _save_replay(self, request, response) -> None:
        del request
        self._require("save_replay", _STATUS.in_game, _STATUS.ended)
        if self._replay is not None:
            raise RequestError("save_replay", ["a replay being watched cannot be saved"])
        if self._map_name not in MINI_GAMES:
            raise RequestError("save_replay", ["the simulator saves replays of the "
                                               "mini-games only, not yet of melee games"])
        outcome = int(self._state.outcome)
        response.save_replay.data = Replay(
            self._map_name, self._map_path, np.asarray(self._episode_key).tolist(),
            tuple(self._fmt.screen_size), tuple(self._fmt.minimap_size),
            [(count, list(calls)) for count, calls in self._steps],
            None if outcome == Outcome.RUNNING else outcome).to_bytes()

    def _read_replay(self, kind: str, request, error) -> Replay | None:
        """The replay of a `replay_info` or `start_replay` request; None (with `error`
        set) if there is none or it does not parse."""
        try:
            if request.HasField("replay_data"):
                data = request.replay_data
            elif request.replay_path:
                data = pathlib.Path(request.replay_path).read_bytes()
            else:
                error.error = error.Error.Value("MissingReplay")
                error.error_details = f"{kind} needs replay_path or replay_data"
                return None
        except OSError as e:
            error.error = error.Error.Value("InvalidReplayPath")
            error.error_details = f"cannot read {request.replay_path!r}: {e}"
            return None
        try:
            replay = Replay.from_bytes(data)
            _check_replay(replay)
            return replay
        except ValueError as e:
            error.error = error.Error.Value("InvalidReplayData")
            error.error_details = str(e)
            return None

    def _replay_info(self, request, response) -> None:
        replay = self._read_replay("replay_info", request, response.replay_info)
        if replay is None:
            return
        info = response.replay_info
        info.map_name, info.local_map_path = replay.map_name, replay.map_path
        player = info.player_info.add()
        player.player_info.player_id = 1
        player.player_info.type = sc2api.PlayerType.Value("Participant")
        player.player_info.race_requested = player.player_info.race_actual = TERRAN
        if replay.result is not None:
            player.player_result.player_id, player.player_result.result = 1, replay.result
        info.game_duration_loops = replay.game_loops
        info.game_duration_seconds = replay.game_loops / 22.4
        info.game_version, info.base_build = GAME_VERSION, BASE_BUILD
        info.data_build = BASE_BUILD

    def _start_replay(self, request, response) -> None:
        self._require("start_replay", _STATUS.launched)
        error = response.start_replay
        replay = self._read_replay("start_replay", request, error)
        if replay is None:
            return
        if request.observed_player_id not in (0, 1):
            error.error = error.Error.Value("InvalidObservedPlayerId")
            error.error_details = (f"observed_player_id {request.observed_player_id}: the "
                                   f"mini-games have one player, 1")
            return
        layers = request.options.feature_layer
        sizes = ((layers.resolution.x, layers.resolution.y),
                 (layers.minimap_resolution.x, layers.minimap_resolution.y))
        if not request.options.HasField("feature_layer") or sizes != (replay.screen_size,
                                                                         replay.minimap_size):
            error.error = error.Error.Value("MissingOptions")
            error.error_details = (f"the replay plays back with options.feature_layer at its "
                                   f"recorded resolutions, screen {replay.screen_size} and "
                                   f"minimap {replay.minimap_size}; got {sizes}")
            return
        self._map_name, self._map_path, self._options = (replay.map_name, replay.map_path,
                                                         request.options)
        self._fmt = specs.ObservationFormat(
            screen_size=replay.screen_size, minimap_size=replay.minimap_size,
            use_feature_units=request.options.raw, use_raw_units=request.options.raw)
        self._reset(jnp.asarray(replay.key, jnp.uint32))
        self._replay, self._replay_next, self._replayed = replay, 0, []
        self.status = _STATUS.in_replay
