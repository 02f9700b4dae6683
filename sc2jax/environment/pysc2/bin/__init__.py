"""PySC2's `pysc2.bin`: the agent runner."""
