"""The StarCraft II API answered by the simulator: one game, as one game process has.

`GameService.handle(request) -> response` takes `sc2api.Request` protos and returns
`sc2api.Response` protos; the websocket server (`server.py`) only moves bytes. The flow
is the real game's (reference/pysc2_facts.md §6):

    ping → create_game (the mini-game by map name, one Participant) → join_game (the
    feature-layer resolutions) → [action → step → observation]* → restart_game → ...
    → leave_game → quit

Status goes launched → init_game → in_game → ended (when the episode ends; the
observation then carries a `player_result`) → launched (after leave) → quit.

A step runs exactly as `Simulator.step` does for the same actions and keys, so a client
sees the in-process simulator's episodes bit for bit: `random_seed` seeds the episode
keys as `SC2Env(seed=...)` does, each game start (join or restart) draws the next key.
Anything the simulator does not do is answered with `Response.error`.
"""

from __future__ import annotations

import functools
import logging
import pathlib

import jax
import numpy as np

from sc2jax.environment.engine.compiled import compiled, simulator
from sc2jax.environment.engine.minigames import MAPS, get_map
from sc2jax.environment.engine.observation import api_units
from sc2jax.environment.engine.rules.state import Outcome
from sc2jax.environment.engine.rules.units import UNIT_DATA, UnitType
from sc2jax.environment.engine.simulator import EnvParams
from sc2jax.environment.interface import specs
from sc2jax.environment.interface.dense import to_dense
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall, validate_function_call
from sc2jax.environment.interface.observation_tables import TERRAN
from sc2jax.environment.sc2api import proto_actions, proto_observation
from sc2jax.environment.sc2api.controller import RequestError
from sc2jax.environment.sc2api.protos import sc2api

GAME_VERSION = "4.10.0"
BASE_BUILD = 75689
RESET_STEP_MUL = 8
"""The step_mul of the simulator that starts episodes (any would do: the state does not
depend on it; 8, PySC2's default, shares its compiled reset with SC2Env's)."""
MAX_STEP_COUNT = 10_000
"""The most game loops one `RequestStep` may run here."""

SC2_NAMES = {
    UnitType.MARINE: "Marine", UnitType.ZERGLING: "Zergling", UnitType.ROACH: "Roach",
    UnitType.BANELING: "Baneling", UnitType.SCV: "SCV", UnitType.BEACON: "Beacon_Terran",
    UnitType.MINERAL_SHARD: "NaturalMinerals", UnitType.MINERAL_FIELD: "MineralField",
    UnitType.VESPENE_GEYSER: "VespeneGeyser", UnitType.COMMAND_CENTER: "CommandCenter",
    UnitType.SUPPLY_DEPOT: "SupplyDepot", UnitType.BARRACKS: "Barracks",
    UnitType.REFINERY: "Refinery",
}
"""The game's names of the simulator's unit types (`data` replies)."""

SUPPORTED = ("ping", "create_game", "join_game", "restart_game", "leave_game", "quit",
             "game_info", "data", "action", "step", "observation")
"""The requests the simulator answers; the others get `Response.error`."""

log = logging.getLogger(__name__)
_PARAMS = EnvParams(game_steps_per_episode=np.int32(0))  # The map's own timer ends games.
_STATUS = sc2api.Status


@functools.cache
def _act(sim):
    return jax.jit(sim.act)


@functools.cache
def _api_units(sim):
    return jax.jit(lambda state: api_units(state, sim.renderer))


class GameService:
    """One simulated game process answering SC2 API requests."""

    def __init__(self):
        self.status = _STATUS.launched
        self._map_name: str | None = None
        self._map_path = ""
        self._seed_key = None
        self._options = None
        self._fmt: specs.ObservationFormat | None = None
        self._state = None
        self._last_observation = None
        self._pending: list[FunctionCall] = []

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
            name = pathlib.PurePath(self._map_path.replace("\\", "/")).stem
        elif request.HasField("battlenet_map_name"):
            name = request.battlenet_map_name
        else:
            error.error = error.Error.Value("MissingMap")
            error.error_details = "create_game needs local_map or battlenet_map_name"
            return
        if name not in MAPS:
            error.error = error.Error.Value("InvalidMapPath")
            error.error_details = (f"map {name!r} is not a mini-game of the simulator; "
                                   f"it has {sorted(MAPS)}")
            return
        participants = [p for p in request.player_setup
                        if p.type == sc2api.PlayerType.Value("Participant")]
        if len(request.player_setup) != 1 or len(participants) != 1:
            error.error = error.Error.Value("InvalidPlayerSetup")
            error.error_details = (f"the simulator plays the mini-games with one Participant "
                                   f"and no Computer; got {len(participants)} participants "
                                   f"among {len(request.player_setup)} players")
            return
        seed = (request.random_seed if request.HasField("random_seed")
                else int(np.random.SeedSequence().entropy % (2 ** 31)))
        self._map_name = name
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
            if layers.HasField("width") and abs(layers.width - 24) > 1e-6:
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
        self._require("leave_game", _STATUS.in_game, _STATUS.ended)
        self._state, self.status = None, _STATUS.launched

    def _quit(self, request, response) -> None:
        del request, response
        self._state, self.status = None, _STATUS.quit

    def _game_info(self, request, response) -> None:
        del request
        self._require("game_info", _STATUS.in_game, _STATUS.ended)
        info = response.game_info
        info.map_name, info.local_map_path = self._map_name, self._map_path
        info.player_info.add(player_id=1, type=sc2api.PlayerType.Value("Participant"),
                             race_requested=TERRAN, race_actual=TERRAN)
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
        self._require("data", _STATUS.in_game, _STATUS.ended)
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
        for action in request.actions:
            call = proto_actions.from_proto(action)
            try:
                call = validate_function_call(call, self._fmt.types)
                code = sc2api.ActionResult.Value("Success")
            except ValueError:
                call = FunctionCall(FUNCTIONS.no_op.id, [])
                code = sc2api.ActionResult.Value("Error")
            if self.status == _STATUS.in_game:
                self._pending.append(call)
            response.action.result.append(code)

    def _step(self, request, response) -> None:
        self._require("step", _STATUS.in_game, _STATUS.ended)
        count = request.count if request.HasField("count") else 1
        if not 1 <= count <= MAX_STEP_COUNT:
            raise RequestError("step", [f"step count {count} is outside 1..{MAX_STEP_COUNT}"])
        if self.status == _STATUS.in_game:
            calls = self._pending or [FunctionCall(FUNCTIONS.no_op.id, [])]
            self._pending = []
            sim = self._simulator(count)
            for call in calls[:-1]:
                self._state = _act(sim)(self._state, to_dense(call, self._fmt.types))
            # While the game runs, `Simulator.step` is `advance` then `observe`: the
            # program `SC2Env` compiles for the same format, shared with it.
            self._state, timestep = compiled(sim, False)[1](
                self._state, to_dense(calls[-1], self._fmt.types), _PARAMS)
            self._last_observation = timestep.observation
            if int(self._state.outcome) != Outcome.RUNNING:
                self.status = _STATUS.ended
        response.step.simulation_loop = int(self._state.game_loop)

    def _observation(self, request, response) -> None:
        del request
        self._require("observation", _STATUS.in_game, _STATUS.ended)
        obs = jax.device_get(self._last_observation)
        outcome = int(self._state.outcome)
        result = None if outcome == Outcome.RUNNING else outcome  # Result values match.
        response.observation.CopyFrom(proto_observation.encode(obs, self._fmt, result=result))
        raw_data = response.observation.observation.raw_data
        raw_data.player.camera.x = float(self._state.camera[0])
        raw_data.player.camera.y = float(self._state.camera[1])
        if self._options.raw:
            units = jax.device_get(_api_units(self._simulator(RESET_STEP_MUL))(self._state))
            proto_observation.encode_units(units, raw_data)

    # Internals.

    def _simulator(self, step_mul: int):
        return simulator(self._map_name, self._fmt, step_mul, 0, 1.0, 1.0, False)

    def _start(self) -> None:
        """Starts an episode with the next key, as `SC2Env.reset` does."""
        self._seed_key, key = jax.random.split(self._seed_key)
        self._state, timestep = compiled(self._simulator(RESET_STEP_MUL), False)[0](key, _PARAMS)
        self._last_observation = timestep.observation
        self._pending = []
        self.status = _STATUS.in_game
