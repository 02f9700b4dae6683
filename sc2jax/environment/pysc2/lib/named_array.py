"""PySC2's `pysc2.lib.named_array`: arrays and dicts read by name."""

from sc2jax.environment.interface.named import NamedDict, NamedNumpyArray

__all__ = ["NamedDict", "NamedNumpyArray"]
