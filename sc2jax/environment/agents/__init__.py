"""Agents that need no learning: the paper's random policy and scripted agents."""

from sc2jax.environment.agents.random_agent import random_action
from sc2jax.environment.agents.scripted import (
    SCRIPTED_MAPS,
    required_format,
    scripted_policy,
)
