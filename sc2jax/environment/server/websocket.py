"""An SC2-API server backed by the simulator: a stand-in for the game process.

    python -m sc2jax.environment.server --port 5000
    python -m sc2jax.environment.server -listen 127.0.0.1 -port 5000 -dataDir D -tempDir T

It answers the StarCraft II API at `ws://HOST:PORT/sc2api` with `GameService`, so any
SC2-API client (sc2jax's own, or PySC2) can play the mini-games on the simulator. As the
game does, it accepts requests in BINARY frames and in TEXT frames that are not valid
UTF-8 (known clients send those), replies in BINARY frames, answers one request at a
time (from any number of connections), and exits after `RequestQuit`. A malformed
request gets `Response.error`; a frame over `--max_message_mb` closes that connection
(code 1009) and the server goes on.

It takes the game's own command-line arguments (`-listen`, `-port`, and ignores
`-dataDir`, `-tempDir`, `-displayMode`, ...), so a launcher that starts the game can
start it instead.
"""

from __future__ import annotations

import argparse
import http
import logging
import sys
import threading
from collections.abc import Callable, Sequence

from google.protobuf.message import DecodeError
from websockets.exceptions import ConnectionClosed
from websockets.sync.server import ServerConnection, serve

from sc2jax.environment.sc2api.protos import sc2api
from sc2jax.environment.server.game_service import GameService
from sc2jax.environment.server.install_layout import write_sc2path

PATH = "/sc2api"
MAX_MESSAGE_BYTES = 64 << 20

log = logging.getLogger(__name__)


def _reply_error(message: str) -> bytes:
    response = sc2api.Response(error=[message])
    return response.SerializeToString()


class Sc2ApiServer:
    """The websocket server around one `GameService`.

    Args:
      host, port: where to listen (port 0 picks a free one; see `port`).
      max_message_bytes: the largest request frame accepted.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 0,
                 max_message_bytes: int = MAX_MESSAGE_BYTES):
        self.service = GameService()
        self._lock = threading.Lock()
        self._stopped = False
        self._server = serve(self._connection, host, port, max_size=max_message_bytes,
                             process_request=self._check_path, compression=None,
                             ping_interval=None, close_timeout=2)

    @property
    def port(self) -> int:
        return self._server.socket.getsockname()[1]

    def serve_forever(self) -> None:
        """Serves until `RequestQuit` (or `shutdown`)."""
        self._server.serve_forever()

    def shutdown(self) -> None:
        """Stops serving (once; later calls do nothing)."""
        with self._lock:
            if self._stopped:
                return
            self._stopped = True
        self._server.shutdown()

    def _check_path(self, connection, request):
        if request.path != PATH:
            return connection.respond(http.HTTPStatus.NOT_FOUND, f"the SC2 API is at {PATH}\n")
        return None

    def _connection(self, connection: ServerConnection) -> None:
        while True:
            try:
                message = connection.recv(decode=False)
            except ConnectionClosed:
                return
            reply, quit_now = self.answer(message)
            if quit_now:  # The client may not wait for the reply.
                threading.Thread(target=self.shutdown, daemon=True).start()
            try:
                connection.send(reply)
            except ConnectionClosed:
                return
            if quit_now:
                connection.close()
                return

    def answer(self, message: bytes) -> tuple[bytes, bool]:
        """The serialized reply to one request frame, and whether it was a quit."""
        try:
            request = sc2api.Request.FromString(bytes(message))
        except DecodeError as e:
            return _reply_error(f"malformed request ({len(message)} bytes): {e}"), False
        with self._lock:  # Requests from several connections take turns.
            response = self.service.handle(request)
        return response.SerializeToString(), request.HasField("quit")


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
    server = Sc2ApiServer(args.host, args.port, int(args.max_message_mb * 2 ** 20))
    announce(f"sc2jax SC2 API server listening on ws://{args.host}:{server.port}{PATH}")
    server.serve_forever()
    return 0

