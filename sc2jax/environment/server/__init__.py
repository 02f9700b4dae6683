"""The SC2-API server over the simulator: any StarCraft II API client (sc2jax's own, or
PySC2) plays the mini-games on it.

    python -m sc2jax.environment.server --port 5000
"""

from sc2jax.environment.server.game_service import GameService
from sc2jax.environment.server.websocket import Sc2ApiServer, main

__all__ = ["GameService", "Sc2ApiServer", "main"]
