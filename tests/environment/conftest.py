"""Fixtures of the environment tests (the helpers are in `helpers.py`)."""

import threading

import pytest

from sc2jax.environment.server import Sc2ApiServer


@pytest.fixture
def server():
    """A fresh SC2-API server per test (`GameEnv.close` quits it); compiled code is shared."""
    server = Sc2ApiServer(port=0)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server
    server.shutdown()
