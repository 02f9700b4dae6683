"""sc2jax: the StarCraft II Learning Environment (SC2LE) in JAX."""

__version__ = "0.1.0"
