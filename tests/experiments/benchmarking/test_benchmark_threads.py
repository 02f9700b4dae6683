"""The simulator benchmark's `--threads`: each XLA:CPU thread-pool size measured in a
process of its own, and merged into one table (the benchmark module defines absl flags,
so it is run, not imported beside the other tests)."""

import re
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # the slow tier: left out of `pytest -m "not slow"`

BENCHMARK = [sys.executable, "-m", "sc2jax.experiments.benchmark", "--maps=MoveToBeacon",
             "--screen_size=16", "--minimap_size=16", "--steps=1", "--repeats=1",
             "--smax=False"]


def run(*flags):
    return subprocess.run(BENCHMARK + list(flags), capture_output=True, text=True,
                          timeout=300)


def rows(stdout):
    """(envs, devices, threads) of each MoveToBeacon row of the printed table."""
    return re.findall(r"^\| MoveToBeacon \| (\d+) \| (\d+) \| ([^|]+?) \|", stdout, re.M)


def test_each_thread_count_runs_in_its_own_process_and_the_tables_merge():
    out = run("--num_envs=2", "--devices=1,2", "--threads=1,0")
    assert out.returncode == 0, out.stderr[-2000:]
    # One thread: one-device runs only; the default pool: every device count.
    assert rows(out.stdout) == [("2", "1", "1"), ("2", "1", "XLA default"),
                                ("2", "2", "XLA default")]
    assert "--threads=1,0" in out.stdout


def test_bad_thread_counts_are_refused_before_anything_runs():
    for value, allowed in (("1,1", "distinct integers >= 0"), ("-1", "integers >= 0"),
                           ("x", "integers >= 0")):
        out = run("--num_envs=1", f"--threads={value}")
        assert out.returncode != 0
        assert "--threads must be" in out.stderr and allowed in out.stderr
        assert "compiled and warmed up" not in out.stderr
