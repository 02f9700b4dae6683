"""PySC2's `pysc2.env`: the environment and the agent loop."""
