"""Deprecated: moved to `sc2jax.environment.engine.simulator`; this alias goes after one release."""

import warnings

from sc2jax.environment.engine.simulator import *  # noqa: F403

warnings.warn("sc2jax.environment.simulator is deprecated; import "
              "sc2jax.environment.engine.simulator (or the same names from sc2jax.environment)",
              DeprecationWarning, stacklevel=2)
