"""sc2jax.experiments."""
