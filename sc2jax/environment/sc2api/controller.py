"""A StarCraft II API client: requests over the game's websocket, with ids and timeouts.

    controller = Controller.connect("127.0.0.1", port, timeout_seconds=60)
    controller.ping()
    controller.create_game(map_path="mini_games/MoveToBeacon.SC2Map", random_seed=1)

Every request carries an incrementing id, and the reply must carry the same one. A
reply's `error`, or an error in a create/join/restart reply, raises `RequestError`
naming the request; a closed or broken connection raises `ConnectionError`, and a reply
that does not come within the timeout raises `TimeoutError` (the connection is then
unusable, as the reply may still come). Requests go in BINARY frames.
"""

from __future__ import annotations

import time

import websocket

from sc2jax.environment.sc2api.protos import sc2api

QUIT_ID = 999999999
"""The id PySC2 gives `RequestQuit` (no reply is awaited)."""


class RequestError(Exception):
    """The game answered a request with an error.

    Attributes:
      request: the request's kind, e.g. "create_game".
      errors: the error strings and codes of the reply.
    """

    def __init__(self, request: str, errors: list[str]):
        self.request, self.errors = request, errors
        super().__init__(f"{request} failed: {'; '.join(errors)}")


class Controller:
    """One connection to a game (or to `server.py`). Use `Controller.connect`.

    Attributes:
      status: the game's status after the last reply (`sc2api.Status`), or None.
      on_quit: called after `quit` (e.g. to stop the game's process), or None.
    """

    def __init__(self, socket: websocket.WebSocket, timeout_seconds: float):
        self._socket = socket
        self._timeout = timeout_seconds
        self._next_id = 1
        self.status = None
        self.on_quit = None

    @classmethod
    def connect(cls, host: str, port: int, timeout_seconds: float = 120.0,
                connect_seconds: float = 120.0, is_running=None) -> Controller:
        """Connects to `ws://host:port/sc2api`, retrying once a second.

        Args:
          host, port: where the game listens.
          timeout_seconds: how long each request may take.
          connect_seconds: how long to keep retrying the connection.
          is_running: an optional callable; if it returns False, stop retrying (the
            process that should listen has exited).

        Raises:
          ValueError: for a non-positive timeout.
          ConnectionError: if no connection is made in time.
        """
        if timeout_seconds <= 0 or connect_seconds <= 0:
            raise ValueError(f"timeouts must be positive, got timeout_seconds="
                             f"{timeout_seconds!r}, connect_seconds={connect_seconds!r}")
        url = f"ws://{host}:{port}/sc2api"
        deadline = time.monotonic() + connect_seconds
        while True:
            try:
                socket = websocket.create_connection(url, timeout=timeout_seconds,
                                                     enable_multithread=False)
                return cls(socket, timeout_seconds)
            except (OSError, websocket.WebSocketException) as e:
                error = e
            if is_running is not None and not is_running():
                raise ConnectionError(f"the game process exited before listening on {url}")
            if time.monotonic() >= deadline:
                raise ConnectionError(f"no SC2 API at {url} after {connect_seconds:g} s: "
                                      f"{error}") from error
            time.sleep(1.0)

    # The protocol.

    def request(self, kind: str, message):
        """Sends one request of `kind` (a `Request` field name) and returns the reply's
        field of the same name.

        Raises:
          RequestError, ConnectionError, TimeoutError: see the module docstring.
        """
        request = sc2api.Request(id=self._next_id)
        self._next_id += 1
        getattr(request, kind).CopyFrom(message)
        response = self._exchange(kind, request)
        if response.error:
            raise RequestError(kind, list(response.error))
        reply = getattr(response, kind)
        if "error" in reply.DESCRIPTOR.fields_by_name and reply.HasField("error"):
            raise RequestError(kind, [type(reply).Error.Name(reply.error), reply.error_details])
        return reply

    def _exchange(self, kind: str, request):
        try:
            self._socket.send_binary(request.SerializeToString())
            data = self._socket.recv()
        except websocket.WebSocketTimeoutException as e:
            self.close()
            raise TimeoutError(f"{kind}: no reply within {self._timeout:g} s") from e
        except (OSError, websocket.WebSocketException) as e:
            self.close()
            raise ConnectionError(f"{kind}: the connection to the game was lost: "
                                  f"{type(e).__name__}: {e}") from e
        if not data and not self._socket.connected:
            raise ConnectionError(f"{kind}: the game closed the connection")
        if isinstance(data, str):
            data = data.encode("latin1")
        try:
            response = sc2api.Response.FromString(data)
        except Exception as e:
            raise ConnectionError(f"{kind}: the game's reply does not parse: {e}") from e
        if response.id != request.id:
            raise ConnectionError(f"{kind}: the reply has id {response.id}, the request "
                                  f"{request.id}")
        if response.HasField("status"):
            self.status = response.status
        return response

    def close(self) -> None:
        try:
            self._socket.close(timeout=1)
        except (OSError, websocket.WebSocketException):
            pass

    # Requests, as PySC2's RemoteController names them.

    def ping(self):
        return self.request("ping", sc2api.RequestPing())

    def create_game(self, *, map_path: str = "", map_data: bytes = b"",
                    battlenet_map_name: str = "", players=(), disable_fog: bool = False,
                    random_seed: int | None = None, realtime: bool = False):
        """Creates a game. `players` is a list of `sc2api.PlayerSetup` (default: one
        Participant)."""
        create = sc2api.RequestCreateGame(disable_fog=disable_fog, realtime=realtime)
        if battlenet_map_name:
            create.battlenet_map_name = battlenet_map_name
        else:
            create.local_map.map_path = map_path
            if map_data:
                create.local_map.map_data = map_data
        create.player_setup.extend(players or [sc2api.PlayerSetup(
            type=sc2api.PlayerType.Value("Participant"))])
        if random_seed is not None:
            create.random_seed = random_seed
        return self.request("create_game", create)

    def join_game(self, options, race: int = 1, player_name: str = ""):
        """Joins as a player with `sc2api.InterfaceOptions`; returns the reply."""
        join = sc2api.RequestJoinGame(race=race, options=options)
        if player_name:
            join.player_name = player_name
        return self.request("join_game", join)

    def game_info(self):
        return self.request("game_info", sc2api.RequestGameInfo())

    def data(self):
        return self.request("data", sc2api.RequestData(
            ability_id=True, unit_type_id=True, upgrade_id=True, buff_id=True, effect_id=True))

    def step(self, count: int = 1):
        return self.request("step", sc2api.RequestStep(count=count))

    def observe(self, game_loop: int | None = None, disable_fog: bool = False):
        observation = sc2api.RequestObservation(disable_fog=disable_fog)
        if game_loop is not None:
            observation.game_loop = game_loop
        return self.request("observation", observation)

    def actions(self, actions):
        return self.request("action", sc2api.RequestAction(actions=list(actions)))

    def restart(self):
        return self.request("restart_game", sc2api.RequestRestartGame())

    def leave(self):
        return self.request("leave_game", sc2api.RequestLeaveGame())

    def save_replay(self) -> bytes:
        return self.request("save_replay", sc2api.RequestSaveReplay()).data

    def start_replay(self, replay_path: str = "", replay_data: bytes = b"", options=None,
                     observed_player_id: int = 1, disable_fog: bool = False):
        start = sc2api.RequestStartReplay(observed_player_id=observed_player_id,
                                          disable_fog=disable_fog)
        if replay_data:
            start.replay_data = replay_data
        else:
            start.replay_path = replay_path
        if options is not None:
            start.options.CopyFrom(options)
        return self.request("start_replay", start)

    def replay_info(self, replay_path: str = "", replay_data: bytes = b""):
        info = sc2api.RequestReplayInfo()
        if replay_data:
            info.replay_data = replay_data
        else:
            info.replay_path = replay_path
        return self.request("replay_info", info)

    def quit(self) -> None:
        """Asks the game to quit; does not wait for a reply."""
        request = sc2api.Request(id=QUIT_ID, quit=sc2api.RequestQuit())
        try:
            self._socket.send_binary(request.SerializeToString())
        except (OSError, websocket.WebSocketException):
            pass
        self.close()
        if self.on_quit is not None:
            self.on_quit()
