"""sc2jax.networks."""
