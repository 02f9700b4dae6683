"""PySC2's `pysc2.lib`: actions, features, units and named arrays."""
