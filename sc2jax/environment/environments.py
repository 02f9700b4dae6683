"""Deprecated: moved to `sc2jax.environment.sc2_env`; this alias goes after one release."""

import warnings

from sc2jax.environment.interface.layout import to_padded_layout, to_pysc2_layout  # noqa: F401
from sc2jax.environment.sc2_env import *  # noqa: F403

warnings.warn("sc2jax.environment.environments is deprecated; import sc2jax.environment.sc2_env "
              "(or the same names from sc2jax.environment)", DeprecationWarning, stacklevel=2)
