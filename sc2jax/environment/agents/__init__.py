"""Agents that need no learning: the paper's random policy and scripted agents."""

from sc2jax.environment.agents.random_agent import random_action
