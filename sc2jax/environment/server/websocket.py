"""An SC2-API server backed by the simulator: a stand-in for the game process.

    python -m sc2jax.environment.server --port 5000
    python -m sc2jax.environment.server -listen 127.0.0.1 -port 5000 -dataDir D -tempDir T

It answers the StarCraft II API at `ws://HOST:PORT/sc2api` with `GameService`, so any
SC2-API client (sc2jax's own, or PySC2) can play the mini-games on the simulator. As the
game does, it accepts requests in BINARY frames and in TEXT frames that are not valid
UTF-8 (known clients send those), replies in BINARY frames, answers one request at a
time, and exits after `RequestQuit`. A malformed request gets `Response.error`; a frame
over `--max_message_mb` closes that connection (code 1009) and the server goes on.

It has no authentication, so it guards the one game it runs:

- **One owner.** The connection whose `create_game` or `start_replay` starts a game owns
  it until it leaves: other connections get an error for anything but `ping` (`quit`
  included). When the owner disconnects, its game is left, so the next client starts
  cleanly.
- **Local pages only.** A handshake with an `Origin` header of another host than this
  machine (a web page the user visits) is refused (403); API clients send none, or a
  local one.
- **Bounded.** At most `MAX_CONNECTIONS` connections at once (more get 503), frames of
  at most `MAX_MESSAGE_BYTES` (8 MiB: a mini-game map is about 30 KB and a simulator
  replay of the longest mini-game, 2,520 agent steps, about 100 KB per call a step),
  and at most `game_service.MAX_ACTIONS_PER_STEP` actions a step.

It takes the game's own command-line arguments (`-listen`, `-port`, and ignores
`-dataDir`, `-tempDir`, `-displayMode`, ...), so a launcher that starts the game can
start it instead.
"""

from __future__ import annotations

import argparse
import http
import logging
import socket
import sys
import threading
import urllib.parse
from collections.abc import Callable, Sequence

from google.protobuf.message import DecodeError
from websockets.exceptions import ConnectionClosed
from websockets.sync.server import ServerConnection, serve

from sc2jax.environment.sc2api.protos import sc2api
from sc2jax.environment.server.game_service import GameService
from sc2jax.environment.server.install_layout import write_sc2path

PATH = "/sc2api"
MAX_MESSAGE_BYTES = 8 << 20
MAX_CONNECTIONS = 16
LOOPBACK = ("127.0.0.1", "localhost", "::1")
OPEN_TO_ALL = ("ping",)
"""The requests answered to connections that do not own the game."""

log = logging.getLogger(__name__)


def _reply_error(message: str) -> bytes:
    response = sc2api.Response(error=[message])
    return response.SerializeToString()


class Sc2ApiServer:
    """The websocket server around one `GameService`.

    Args:
      host, port: where to listen (port 0 picks a free one; see `port`).
      max_message_bytes: the largest request frame accepted.
      max_connections: the most connections at once.
      melee_slots: the unit slots of ladder maps' games (`GameService`).
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 0,
                 max_message_bytes: int = MAX_MESSAGE_BYTES,
                 max_connections: int = MAX_CONNECTIONS, melee_slots: int | None = None):
        self.service = GameService(melee_slots)
        self._lock = threading.Lock()
        self._stopped = self._quitting = False
        self._closed = threading.Event()
        self._owner: object | None = None
        self._open: set[ServerConnection] = set()
        self._max_connections = max_connections
        self._server = serve(self._connection, host, port, max_size=max_message_bytes,
                             process_request=self._check_request, compression=None,
                             ping_interval=None, close_timeout=2)

    @property
    def port(self) -> int:
        return self._server.socket.getsockname()[1]

    def serve_forever(self) -> None:
        """Serves until `RequestQuit` (or `shutdown`), and returns once every connection
        is closed and its handler has ended (so a process can exit cleanly)."""
        self._server.serve_forever()
        self.shutdown()

    def shutdown(self) -> None:
        """Stops serving: drops every connection (without the closing handshake, which a
        client that stopped reading would never finish) and waits for their handlers.
        Calls after the first wait for it to finish."""
        with self._lock:
            first, self._stopped = not self._stopped, True
            connections = list(self._open)
        if first:
            for connection in connections:
                try:
                    connection.socket.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass  # Already closed.
            self._server.shutdown()
            self._closed.set()
        self._closed.wait()

    def _check_request(self, connection, request):
        if request.path != PATH:
            return connection.respond(http.HTTPStatus.NOT_FOUND, f"the SC2 API is at {PATH}\n")
        origin = request.headers.get("Origin")
        if origin is not None and urllib.parse.urlsplit(origin).hostname not in LOOPBACK:
            return connection.respond(http.HTTPStatus.FORBIDDEN,
                                      f"connections from pages of {origin} are refused\n")
        if len(self._open) >= self._max_connections:
            return connection.respond(http.HTTPStatus.SERVICE_UNAVAILABLE,
                                      f"{self._max_connections} connections are open; the "
                                      f"most this server takes\n")
        return None

    def _connection(self, connection: ServerConnection) -> None:
        with self._lock:
            if self._stopped:
                return
            self._open.add(connection)
        try:
            self._serve(connection)
        finally:
            with self._lock:
                self._open.discard(connection)
            self.gone(connection)

    def gone(self, client: object) -> None:
        """`client` has disconnected: its game, if it owns one, is left."""
        with self._lock:
            if self._owner is client and client is not None:
                self._owner = None
                self.service.abandon()

    def _serve(self, connection: ServerConnection) -> None:
        while True:
            try:
                message = connection.recv(decode=False)
            except ConnectionClosed:
                return
            reply, quit_now = self.answer(message, connection)
            try:
                connection.send(reply)
            except ConnectionClosed:
                return
            finally:
                if quit_now:  # After the reply (a client may not wait for it).
                    threading.Thread(target=self.shutdown, daemon=True).start()
            if quit_now:
                return

    def answer(self, message: bytes, client: object = None) -> tuple[bytes, bool]:
        """The serialized reply to one request frame from `client` (a connection; None:
        the in-process caller), and whether it was a quit."""
        try:
            request = sc2api.Request.FromString(bytes(message))
        except DecodeError as e:
            return _reply_error(f"malformed request ({len(message)} bytes): {e}"), False
        kind = request.WhichOneof("request")
        with self._lock:  # Requests from several connections take turns.
            if self._quitting:
                return _reply_error("the server has quit"), False
            if self._owner not in (None, client) and kind not in OPEN_TO_ALL:
                response = sc2api.Response(error=[
                    f"{kind}: the game belongs to another connection; this one may only "
                    f"{', '.join(OPEN_TO_ALL)} until it leaves"], status=self.service.status)
                if request.HasField("id"):
                    response.id = request.id
                return response.SerializeToString(), False
            response = self.service.handle(request)
            if self.service.status in (sc2api.Status.launched, sc2api.Status.quit):
                self._owner = None
            elif kind in ("create_game", "start_replay"):
                self._owner = client
            self._quitting = request.HasField("quit")
        return response.SerializeToString(), self._quitting

def _parse(argv: Sequence[str]) -> tuple[argparse.Namespace, list[str]]:
    parser = argparse.ArgumentParser(
        prog="python -m sc2jax.environment.server",
        description="Serve the StarCraft II API over the sc2jax simulator.",
        add_help=False, allow_abbrev=False)  # The game's `-headlessNoRender` is not -h.
    parser.add_argument("--help", action="help", help="show this help and exit")
    parser.add_argument("--port", "-port", type=int, default=5000,
                        help="port to listen on (0: any free port)")
    parser.add_argument("--host", "-listen", default="127.0.0.1", help="address to listen on")
    parser.add_argument("--max_message_mb", type=float, default=MAX_MESSAGE_BYTES / 2 ** 20,
                        help="largest request accepted, in MiB")
    parser.add_argument("--melee_slots", type=int, default=None,
                        help="unit slots of the ladder maps' games (default: enough for two "
                             "players at 200 supply; fewer compile and run faster)")
    parser.add_argument("--write-sc2path", dest="write_sc2path", metavar="DIR",
                        help="write an install-like folder that starts this server, and exit")
    return parser.parse_known_args(list(argv))


def main(argv: Sequence[str] | None = None,
         announce: Callable[[str], None] = lambda line: print(line, flush=True)) -> int:
    args, ignored = _parse(sys.argv[1:] if argv is None else argv)
    if args.write_sc2path:
        announce(f"wrote {write_sc2path(args.write_sc2path)}")
        return 0
    if not 0 <= args.port <= 65535:
        raise SystemExit(f"--port {args.port} is outside 0..65535")
    if args.max_message_mb <= 0:
        raise SystemExit(f"--max_message_mb must be positive, got {args.max_message_mb}")
    if ignored:
        log.info("ignoring game arguments %s", ignored)
    if args.host not in LOOPBACK:
        print(f"warning: listening on {args.host}: this server has no authentication, so "
              f"anyone who can reach it can play its game", file=sys.stderr)
    server = Sc2ApiServer(args.host, args.port, int(args.max_message_mb * 2 ** 20),
                          melee_slots=args.melee_slots)
    announce(f"sc2jax SC2 API server listening on ws://{args.host}:{server.port}{PATH}")
    server.serve_forever()
    return 0

