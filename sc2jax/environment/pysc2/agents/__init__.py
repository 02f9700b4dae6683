"""PySC2's `pysc2.agents`: the base agent and the random agent."""
