"""`python -m sc2jax.environment.server`: see `sc2jax.environment.server.websocket`."""

import sys

from sc2jax.environment.server.websocket import main

sys.exit(main())
