"""sc2jax.replay_sl."""
