"""The server against careless clients and load, over real websockets: clients gone in the
middle of a request, many clients at once with an action flood and mixed step counts.
After each, a correct client plays a whole episode and the memory stays bounded."""

import pathlib
import random
import threading
import time

import pytest

from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall
from sc2jax.environment.sc2api import proto_actions
from sc2jax.environment.sc2api.controller import Controller, RequestError
from sc2jax.environment.sc2api.protos import sc2api
from tests.environment.server.helpers import join_beacon

pytestmark = [pytest.mark.slow, pytest.mark.skipif(
    not pathlib.Path("/proc/self/statm").exists(), reason="reads the memory from /proc")]
ARMY = proto_actions.to_proto(FunctionCall(FUNCTIONS.select_army.id, [[0]]))
MEMORY_BOUND_MB = 200
"""The most the (in-process) server's memory may grow over a test, compiled programs of
the one format included."""


def _rss_mb() -> float:
    pages = int(pathlib.Path("/proc/self/statm").read_text().split()[1])
    return pages * 4096 / 2 ** 20


def _play_episode(port: int) -> None:
    """A correct client joins (once the last owner's game is left), plays MoveToBeacon to
    its end and leaves."""
    controller = Controller.connect("127.0.0.1", port)
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                join_beacon(controller)
                break
            except RequestError as error:
                assert "belongs to another connection" in str(error)
                assert time.monotonic() < deadline, "the last owner's game was never left"
                time.sleep(0.1)
        loops = 0
        while controller.status != sc2api.Status.Value("ended"):
            controller.actions([ARMY])
            loops += 64
            assert controller.step(64).simulation_loop == loops
        assert controller.observe().player_result  # The episode ended with a result.
        controller.leave()
    finally:
        controller.close()


def test_clients_gone_in_the_middle_of_a_request_leave_their_games(server):
    _play_episode(server.port)  # Compiles.
    before = _rss_mb()
    for cut in ("before the reply", "inside a frame"):
        owner = Controller.connect("127.0.0.1", server.port)
        join_beacon(owner)
        if cut == "before the reply":
            step = sc2api.Request(id=7, step=sc2api.RequestStep(count=10_000))
            owner._socket.send_binary(step.SerializeToString())
        else:  # A masked binary frame's header announcing 1 MiB, then 3 bytes of it.
            owner._socket.sock.sendall(b"\x82\xff" + (1 << 20).to_bytes(8, "big")
                                       + b"\x00" * 4 + b"abc")
        owner._socket.sock.close()
        _play_episode(server.port)
    assert _rss_mb() - before < MEMORY_BOUND_MB


def test_many_clients_at_once_are_served_in_turn():
    from sc2jax.environment.server import Sc2ApiServer
    server = Sc2ApiServer(port=0)  # Its own, so that its connections are all this test's.
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        _play_episode(server.port)  # Compiles.
        before = _rss_mb()
        owner = Controller.connect("127.0.0.1", server.port)
        join_beacon(owner)
        refused, failures = [], []

        def intruder(n: int) -> None:
            # Every request is answered: ping, and an error naming the owner for the rest.
            try:
                client = Controller.connect("127.0.0.1", server.port)
                try:
                    for i in range(30):
                        if (n + i) % 3 == 0:
                            assert client.ping().base_build
                            continue
                        try:
                            (client.observe if i % 2 else lambda: client.step(8))()
                        except RequestError as error:
                            assert "belongs to another connection" in str(error)
                            refused.append(n)
                finally:
                    client.close()
            except Exception as error:  # Reported to the test's thread.
                failures.append(repr(error))

        threads = [threading.Thread(target=intruder, args=(n,)) for n in range(14)]
        for thread in threads:
            thread.start()
        rng, loops = random.Random(0), 0
        while owner.status != sc2api.Status.Value("ended"):  # A flood, mixed step counts.
            assert all(r == sc2api.ActionResult.Value("Success")
                       for r in owner.actions([ARMY] * 64).result)
            count = rng.randint(1, 64)
            loops += count
            assert owner.step(count).simulation_loop == loops
            assert owner.observe().observation.game_loop == loops
        for thread in threads:
            thread.join(timeout=120)
        assert not failures, failures
        assert len(refused) == 14 * 20, len(refused)
        owner.close()  # Gone without leaving.
        _play_episode(server.port)
        assert _rss_mb() - before < MEMORY_BOUND_MB
    finally:
        server.shutdown()
