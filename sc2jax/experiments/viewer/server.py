"""The viewer's web server: the page, its pictures, and a person's inputs, over HTTP.

`ViewerServer(host, port)` takes its port at once (so a port in use is refused before
anything is compiled); `start(source)` then serves a `PlaySession`, a `Playback` of a
recorded episode or a `ReplayPlayback` of a human replay from a thread
(Python's `http.server`), and steps it from another at the chosen speed unless paused.
It serves its own three assets (the page, its script and its style) and nothing else
from disk. The page asks for:

| request | answer |
|---|---|
| `GET /api/status` | JSON: the step's numbers (`Frame.status`), paused, speed, layers |
| `GET /api/image/view.png`, `/minimap.png`, `/layer/<set>/<name>.png` | PNG pictures |
| `POST /api/click` | a click (`inputs.call_for_click`), queued for the next step |
| `POST /api/act` | `{"function": id or name, "arguments": [...]}`, queued |
| `POST /api/control` | `{"paused", "speed", "step": n, "reset", "seek": t}` |

A bad input is answered 400 with `{"error": ...}` naming what was wrong.
"""

from __future__ import annotations

import errno
import http.server
import importlib.resources
import io
import json
import threading
import time
import urllib.parse

import numpy as np
from PIL import Image

from sc2jax.experiments.viewer.frames import layer_legend
from sc2jax.experiments.viewer.session import PlaySession, Timeline

ASSETS = {"/": ("index.html", "text/html; charset=utf-8"),
          "/app.js": ("app.js", "text/javascript; charset=utf-8"),
          "/style.css": ("style.css", "text/css; charset=utf-8")}
"""Path -> (file in the package's static folder, content type): all it serves from disk."""

MAX_SPEED = 64.0
MAX_BODY = 64 * 1024


def _asset(name: str) -> bytes:
    return importlib.resources.files("sc2jax.experiments.viewer").joinpath(
        "static", name).read_bytes()


def _png(image: np.ndarray, scale: int = 1) -> bytes:
    picture = Image.fromarray(np.asarray(image, np.uint8))
    if scale > 1:
        picture = picture.resize((picture.width * scale, picture.height * scale),
                                 Image.NEAREST)
    out = io.BytesIO()
    picture.save(out, format="PNG", compress_level=1)
    return out.getvalue()


class ViewerServer:
    """Serves a session (or playback) on http://host:port and steps it.

    Args:
      host: the address to bind (127.0.0.1: this machine only).
      port: the port (0: any free one).
      speed: agent steps per second while playing.
      paused: start paused.

    Raises:
      ValueError: for a bad speed, or a port that is in use or not allowed.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 0, speed: float = 4.0,
                 paused: bool = False):
        if not 0 < speed <= MAX_SPEED:
            raise ValueError(f"speed must be in (0, {MAX_SPEED}] steps per second, got "
                             f"{speed!r}")
        self.source: PlaySession | Timeline | None = None
        self.speed, self.paused = float(speed), bool(paused)
        self._steps_asked = 0
        self._error = ""
        self._stop = threading.Event()
        self._lock = threading.Lock()
        try:
            self._http = http.server.ThreadingHTTPServer((host, port), self._handler())
        except OSError as error:
            if error.errno == errno.EADDRINUSE:
                raise ValueError(f"port {port} on {host} is in use; choose another with "
                                 f"--port (0 picks a free one)") from None
            raise ValueError(f"cannot listen on {host}:{port}: {error.strerror}") from None
        self._http.daemon_threads = True
        self._threads = [threading.Thread(target=self._http.serve_forever, daemon=True),
                         threading.Thread(target=self._run, daemon=True)]

    @property
    def address(self) -> str:
        host, port = self._http.server_address[:2]
        return f"http://{host}:{port}/"

    def start(self, source: PlaySession | Timeline) -> ViewerServer:
        """Serves and steps `source`: a `PlaySession`, or a `Timeline` (`Playback`,
        `ReplayPlayback`)."""
        self.source = source
        for thread in self._threads:
            thread.start()
        return self

    def close(self) -> None:
        """Stops serving and stepping, and frees the port."""
        self._stop.set()
        if self.source is not None:  # Started: serve_forever runs until shut down.
            self._http.shutdown()
            for thread in self._threads:
                thread.join(timeout=10)
        self._http.server_close()

    # Stepping.

    def _run(self) -> None:
        while not self._stop.is_set():
            with self._lock:
                go = not self.paused or self._steps_asked > 0
                if self.paused and self._steps_asked > 0:
                    self._steps_asked -= 1
                delay = 1.0 / self.speed
            start = time.monotonic()
            if go:
                try:
                    self.source.step()
                except Exception as error:  # Shown on the page; the server keeps serving.
                    self._error = f"step failed: {error}"
                    with self._lock:
                        self.paused = True
            self._stop.wait(max(0.0, delay - (time.monotonic() - start)) if go else 0.02)

    def control(self, request: dict) -> None:
        """Applies a control request (see the module's table). Raises ValueError."""
        known = {"paused", "speed", "step", "reset", "seek"}
        if not isinstance(request, dict) or not set(request) <= known:
            raise ValueError(f"a control request takes keys {sorted(known)}, got {request!r}")
        with self._lock:
            if "speed" in request:
                speed = request["speed"]
                if not isinstance(speed, (int, float)) or not 0 < speed <= MAX_SPEED:
                    raise ValueError(f"speed must be in (0, {MAX_SPEED}], got {speed!r}")
                self.speed = float(speed)
            if "paused" in request:
                self.paused = bool(request["paused"])
            if "step" in request:
                n = request["step"]
                if not isinstance(n, int) or not 1 <= n <= 1000:
                    raise ValueError(f"step must be an int in [1, 1000], got {n!r}")
                self.paused, self._steps_asked = True, self._steps_asked + n
        if request.get("reset"):
            if not isinstance(self.source, PlaySession):
                raise ValueError("reset applies to a game, not to a playback (seek to 0)")
            self.source.reset()
        if "seek" in request:
            if not isinstance(self.source, Timeline) or not isinstance(request["seek"], int):
                raise ValueError(f"seek takes an int step of a playback, got "
                                 f"{request['seek']!r}")
            self.source.seek(request["seek"])

    def status(self) -> dict:
        frame = self.source.frame()
        layers = []
        for feature, values in frame.values.items():
            entry = {"name": f"{feature.layer_set}/{feature.name}"}
            if feature.is_categorical:
                entry["legend"] = [[v, list(rgb), label] for v, rgb, label in
                                   layer_legend(feature, values)[:16]]
            else:  # The heat map's range, and the largest value on the layer now.
                entry["scale"] = [0, feature.scale, int(values.max())]
            layers.append(entry)
        with self._lock:
            return {**frame.status, "paused": self.paused, "speed": self.speed,
                    "layers": layers,
                    "error": self._error}

    def image(self, path: str) -> bytes:
        frame = self.source.frame()
        if path == "view.png":
            return _png(frame.view)
        if path == "minimap.png":
            return _png(frame.minimap)
        for feature, panel in frame.panels.items():
            if path == f"layer/{feature.layer_set}/{feature.name}.png":
                return _png(panel, scale=max(1, 192 // panel.shape[0]))
        raise KeyError(path)

    # HTTP.

    def _handler(self):
        server = self

        class Handler(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args):  # Quiet: the page polls several times a second.
                pass

            def _send(self, code: int, body: bytes, kind: str) -> None:
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                self.wfile.write(body)

            def _json(self, code: int, value) -> None:
                self._send(code, json.dumps(value).encode(), "application/json")

            def do_GET(self):
                path = urllib.parse.urlparse(self.path).path
                if path in ASSETS:
                    name, kind = ASSETS[path]
                    return self._send(200, _asset(name), kind)
                if path == "/api/status":
                    return self._json(200, server.status())
                if path.startswith("/api/image/"):
                    try:
                        return self._send(200, server.image(path[len("/api/image/"):]),
                                          "image/png")
                    except KeyError:
                        pass
                self._json(404, {"error": f"no such page: {path}"})

            def do_POST(self):
                path = urllib.parse.urlparse(self.path).path
                length = int(self.headers.get("Content-Length") or 0)
                if length > MAX_BODY:
                    return self._json(413, {"error": "request too large"})
                try:
                    request = json.loads(self.rfile.read(length) or b"{}")
                    if path == "/api/control":
                        server.control(request)
                        return self._json(200, {"ok": True})
                    if path in ("/api/click", "/api/act"):
                        if not isinstance(server.source, PlaySession) or server.source.agent:
                            raise ValueError("this page is watching, not playing: inputs "
                                             "are not taken")
                        if path == "/api/click":
                            call = server.source.click(request)
                        else:
                            if not isinstance(request, dict) or "function" not in request:
                                raise ValueError(f"an action needs a function, got "
                                                 f"{request!r}")
                            call = server.source.submit(
                                (request["function"], request.get("arguments", [])))
                        return self._json(200, {"ok": True, "call": str(call)})
                except (ValueError, TypeError) as error:
                    return self._json(400, {"error": str(error)})
                self._json(404, {"error": f"no such request: {path}"})

        return Handler
