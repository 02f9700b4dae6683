"""Supervised training on a replay dataset (`python -m sc2jax.experiments.train_replays`):
its configuration, the held-out evaluation and the training loop."""
