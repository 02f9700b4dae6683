"""The simulator benchmark's planning (`sc2jax.experiments.benchmarking.memory`): rollouts
grouped to fit in memory, and a count too large for the machine refused before anything
compiles (the benchmark module defines absl flags, so it is run, not imported beside the
other tests)."""

import subprocess
import sys

import jax
import pytest

from sc2jax.environment import ObservationFormat, Simulator
from sc2jax.experiments.benchmarking.memory import carry_bytes, free_memory, memory_groups


def test_memory_groups_keep_order_and_fit_the_budget():
    assert memory_groups([3, 3, 3, 1], 7) == [[0, 1], [2, 3]]
    assert memory_groups([3, 3, 3, 1], None) == [[0, 1, 2, 3]]
    assert memory_groups([9, 2, 2], 7) == [[0], [1, 2]]  # Over the budget alone: its own.
    assert memory_groups([], 7) == []


def test_carry_bytes_are_mostly_the_layers():
    sim = Simulator(map_name="MoveToBeacon",
                    fmt=ObservationFormat(screen_size=64, minimap_size=64), step_mul=8)
    layers = (27 + 11) * 64 * 64 * 4  # int32 feature_screen and feature_minimap.
    assert layers < carry_bytes(sim) < layers + 64 * 1024


def test_a_count_that_cannot_fit_is_refused_before_compiling():
    if free_memory(jax.devices()[0]) is None:
        pytest.skip("this machine does not say how much memory is free")
    out = subprocess.run(
        [sys.executable, "-m", "sc2jax.experiments.benchmark", "--maps=MoveToBeacon",
         "--num_envs=1,100000000", "--devices=1", "--smax=False"],
        capture_output=True, text=True, timeout=120)
    assert out.returncode != 0
    assert "--num_envs=100000000: MoveToBeacon's rollout on 1 device(s) needs about" in (
        out.stderr)
    assert "compiled and warmed up" not in out.stderr
