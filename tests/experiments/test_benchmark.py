"""The simulator benchmark's choice of devices (its timings are not tested)."""

import jax
import pytest

from sc2jax.experiments.benchmark import device_sets


def test_device_sets_split_what_divides_and_drop_repeats():
    local = jax.local_devices()
    assert len(local) == 2, "tests/conftest.py gives the CPU two host devices"
    assert device_sets(64, [1, 0]) == [local[:1], local]
    assert device_sets(64, [2, 0, 1]) == [local, local[:1]]
    # One environment cannot be split: both counts give the one device.
    assert device_sets(1, [1, 2]) == [local[:1]]


def test_device_sets_refuse_more_devices_than_there_are():
    with pytest.raises(ValueError, match="asks for 3 devices, but this process has 2"):
        device_sets(64, [3])
