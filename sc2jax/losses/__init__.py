"""sc2jax.losses."""
