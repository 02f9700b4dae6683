"""PySC2's `pysc2.env.environment`: `StepType` and `TimeStep` (dm_env's, which PySC2's
mirror: `step_type`, `reward`, `discount`, `observation`, and `first()`, `mid()`,
`last()`)."""

from dm_env import StepType, TimeStep

__all__ = ["StepType", "TimeStep"]
