"""The learning-rate sampling flags of the sweep commands (sweep, table1)."""

from __future__ import annotations

import jax
from absl import flags

from sc2jax.experiments.sweeps.sweeping import sample_learning_rates

_NUM_RUNS = flags.DEFINE_integer("num_runs", 8, "Runs in the sweep (trained together).")
_LR_MIN = flags.DEFINE_float("lr_min", 1e-5, "Smallest sampled learning rate.")
_LR_MAX = flags.DEFINE_float("lr_max", 1e-3, "Largest sampled learning rate.")
_SWEEP_SEED = flags.DEFINE_integer("sweep_seed", 0, "Seed of the sampled learning rates.")


def learning_rates_from_flags():
    """float32[--num_runs] rates sampled by the flags (ValueError for a bad value)."""
    return sample_learning_rates(jax.random.PRNGKey(_SWEEP_SEED.value), _NUM_RUNS.value,
                                 _LR_MIN.value, _LR_MAX.value)
