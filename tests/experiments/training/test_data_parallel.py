"""Data-parallel training: two processes of one device each (jax.distributed on CPU, a
localhost coordinator) train as one process with two devices does."""

import dataclasses
import os
import pathlib
import socket
import subprocess
import sys

import numpy as np
import pytest

from sc2jax.experiments.training import data_parallel
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.trainer import run_config, train

WORKER = pathlib.Path(__file__).with_name("data_parallel_worker.py")


def _run(out, *args, devices: int = 1):
    env = {**os.environ, "XLA_FLAGS": f"--xla_force_host_platform_device_count={devices}",
           "JAX_PLATFORMS": "cpu"}
    return subprocess.Popen([sys.executable, str(WORKER), str(out), *map(str, args)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _finish(*processes):
    for p in processes:
        output, _ = p.communicate(timeout=600)
        assert p.returncode == 0, output[-3000:]


def _params(path):
    data = np.load(path)
    return data, [data[f"param{i}"] for i in range(sum(k.startswith("param") for k in data))]


@pytest.mark.slow
def test_two_processes_train_as_one_process_with_two_devices(tmp_path):
    with socket.socket() as s:  # A free port for the coordinator.
        s.bind(("localhost", 0))
        port = s.getsockname()[1]
    two = _run(tmp_path / "two.npz", "--train", tmp_path / "run", devices=2)
    _finish(two)
    coordinator = f"localhost:{port}"
    workers = [_run(tmp_path / "hosts.npz", coordinator, 2, i) for i in range(2)]
    _finish(*workers)
    (two, p2), (hosts, ph) = map(_params, (tmp_path / "two.npz", tmp_path / "hosts.npz"))
    assert (int(two["devices"]), int(hosts["devices"]), int(hosts["processes"])) == (2, 2, 2)
    # 2 processes x 1 device and 1 process x 2 devices: the same program, bit for bit.
    assert all(np.array_equal(a, b) for a, b in zip(p2, ph)) and len(p2) == len(ph) > 10
    np.testing.assert_array_equal(two["loss"], hosts["loss"])
    assert len(set(two["loss"].tolist())) == 3  # Three updates, each its own loss.
    # A run trained on two devices resumes on one: the same program on any number.
    config = run_config(str(tmp_path / "run"))
    assert _steps(tmp_path / "run") == [6] and (tmp_path / "run" / "eval.json").exists()
    result = train(dataclasses.replace(config, total_steps=384), str(tmp_path / "run"),
                   progress=False, log=lambda line: None)
    assert result.evaluation["episodes"] == 4 and _steps(tmp_path / "run")[-1] == 12


def _steps(run_dir):
    return sorted(int(p.name) for p in (run_dir / "checkpoints").iterdir() if p.name.isdigit())


def test_train_refuses_devices_it_cannot_use(tmp_path):
    config = TrainConfig(num_envs=4)
    with pytest.raises(ValueError, match=r"devices=64, but this process has \d+ \(cpu\)"):
        train(config, str(tmp_path), devices=64)
    with pytest.raises(ValueError, match="devices must be a positive int"):
        train(config, str(tmp_path), devices=0)
    assert not any(tmp_path.iterdir())  # Refused before any work.


def test_initialize_refuses_bad_process_numbers_before_joining():
    with pytest.raises(ValueError, match=r"process_id must be in \[0, 2\), got 2"):
        data_parallel.initialize("localhost:1", 2, 2)
    with pytest.raises(ValueError, match="num_processes must be >= 1, got 0"):
        data_parallel.initialize("localhost:1", 0, 0)
