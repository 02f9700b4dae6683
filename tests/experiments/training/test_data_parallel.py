"""Data-parallel and multi-process training with the commands themselves: two processes
of one device each (jax.distributed on CPU, a localhost coordinator) train as one process
with two devices does, resume after one of them is killed, and split a sweep."""

import dataclasses
import json
import os
import signal
import socket
import subprocess
import sys
import time

import jax
import numpy as np
import pytest

from sc2jax.experiments.reporting.metrics_log import read_csv
from sc2jax.experiments.sweeps import sweeping
from sc2jax.experiments.training import data_parallel
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.trainer import load_run, run_config, train

SMALL = ["--map=MoveToBeacon", "--network=fullyconv", "--screen_size=16",
         "--minimap_size=16", "--screen_features=player_relative,selected",
         "--minimap_features=player_relative", "--functions=no_op,select_army,Move_screen",
         "--num_envs=4", "--unroll_length=8", "--seed=3"]
TRAIN = [*SMALL, "--learning_rate=5e-3", "--updates_per_chunk=2", "--total_steps=512",
         "--checkpoint_interval_s=1e-6", "--eval_episodes=4"]  # 16 updates, 8 checkpoints.


def _start(command, *args):
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    return subprocess.Popen([sys.executable, "-m", f"sc2jax.experiments.{command}",
                             *map(str, args)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)


def _finish(*processes):
    outputs = []
    for p in processes:
        output, _ = p.communicate(timeout=600)
        assert p.returncode == 0, output[-3000:]
        outputs.append(output)
    return outputs


def _coordinator() -> str:
    with socket.socket() as s:  # A free port.
        s.bind(("localhost", 0))
        return f"localhost:{s.getsockname()[1]}"


def _processes(command, args, count=2):
    coordinator = ([f"--coordinator={_coordinator()}"] if command == "train" else [])
    return [_start(command, *args, *coordinator, f"--num_processes={count}",
                   f"--process_id={i}") for i in range(count)]


def _steps(run_dir):
    return sorted(int(p.name) for p in (run_dir / "checkpoints").iterdir() if p.name.isdigit())


@pytest.mark.slow
def test_two_processes_train_as_one_with_two_devices_and_resume_after_a_kill(tmp_path):
    one, two = tmp_path / "one", tmp_path / "two"
    reference = _start("train", *TRAIN, "--devices=2", f"--run_dir={one}")
    # Two processes of one device each; process 1 is killed once 4 of 16 updates are
    # checkpointed, process 0 (its collectives failing or hung) after it.
    workers = _processes("train", [*TRAIN, f"--run_dir={two}"])
    deadline = time.time() + 300
    while not ((two / "checkpoints").is_dir() and any(s >= 4 for s in _steps(two))):
        assert time.time() < deadline and workers[1].poll() is None, "no checkpoint"
        time.sleep(0.02)
    for worker in reversed(workers):
        worker.send_signal(signal.SIGKILL)
        worker.communicate()
    killed_at = _steps(two)[-1]
    assert 4 <= killed_at < 16
    outputs = _finish(*_processes("train", [*TRAIN, f"--run_dir={two}"]), reference)
    assert f"Resumed from update {killed_at}" in outputs[0]
    assert "Resumed" not in outputs[1] and "Results in" not in outputs[1]  # Process 0 logs.
    # Killed and resumed, 2 processes x 1 device: the same run as 1 process x 2 devices,
    # bit for bit, with every chunk's row logged once.
    (_, params_one, _), (_, params_two, meta) = load_run(str(one)), load_run(str(two))
    assert meta["update"] == 16 and _same(params_one, params_two)
    assert json.loads((two / "eval.json").read_text())["episodes"] == 4
    rows_one, rows_two = (read_csv(d / "metrics.csv") for d in (one, two))
    np.testing.assert_array_equal(rows_two["step"], np.arange(1, 9) * 64)
    np.testing.assert_array_equal(rows_one["loss"], rows_two["loss"])
    assert len(set(rows_two["loss"].tolist())) == 8
    # A run trained on two devices resumes on one: the same program on any number.
    config = run_config(str(one))
    result = train(dataclasses.replace(config, total_steps=576), str(one),
                   progress=False, log=lambda line: None)
    assert result.evaluation["episodes"] == 4 and _steps(one)[-1] == 18


def _same(a, b) -> bool:
    leaves_a, leaves_b = jax.tree.leaves(a), jax.tree.leaves(b)
    return len(leaves_a) == len(leaves_b) > 10 and all(
        np.array_equal(x, y) for x, y in zip(leaves_a, leaves_b))


@pytest.mark.slow
def test_a_sweep_split_over_two_processes_writes_every_runs_results(tmp_path):
    args = [*SMALL, "--num_runs=4", "--total_steps=256", "--updates_per_chunk=4",
            "--eval_episodes=2", f"--run_dir={tmp_path}"]
    outputs = _finish(*_processes("sweep", args))
    # The last to finish writes the summary (both, when they finish together).
    assert any("mean over runs" in output for output in outputs)
    summary = json.loads((tmp_path / "sweep.json").read_text())
    assert summary["runs"] == [0, 1, 2, 3] and len(summary["run_scores"]) == 4
    assert np.isfinite(summary["run_scores"]).all() and summary["agent_steps_per_run"] == 256
    for i, runs in enumerate(([0, 1], [2, 3])):
        part = json.loads((tmp_path / f"part{i}of2" / "sweep.json").read_text())
        assert part["runs"] == runs and part["run_scores"] == summary["run_scores"][2 * i:][:2]
        assert _steps(tmp_path / f"part{i}of2") == [8]
    curves = read_csv(tmp_path / "curves.csv")
    assert sorted(set(curves["run"].tolist())) == [0, 1, 2, 3] and len(curves["run"]) == 8
    assert (tmp_path / "learning_curves.png").exists()
    # Resumed with another number of processes, the parts would not match: refused.
    config = run_config(str(tmp_path))
    with pytest.raises(ValueError, match=r"split into other parts \(part0of2, part1of2\)"):
        sweeping.run_sweep(config, summary["learning_rates"], str(tmp_path), part=(0, 4))


def test_sweep_parts_are_checked_before_any_work(tmp_path):
    with pytest.raises(ValueError, match=r"0 <= i < n <= 2 \(the runs\), got \(0, 3\)"):
        sweeping.run_sweep(TrainConfig(), [1e-4, 1e-3], str(tmp_path), part=(0, 3))
    assert not any(tmp_path.iterdir())
    (tmp_path / "part0of12").mkdir()
    with pytest.raises(ValueError, match=r"split into other parts \(part0of12\)"):
        sweeping.run_sweep(TrainConfig(), [1e-4, 1e-3], str(tmp_path), part=(1, 2))
    assert [p.name for p in tmp_path.iterdir()] == ["part0of12"]
    with pytest.raises(ValueError, match="actor_device=1 is for train"):
        sweeping.run_sweep(TrainConfig(actor_device=1), [1e-4], str(tmp_path / "a"))


def test_process_numbers_come_from_the_flags_or_the_cluster(monkeypatch):
    for name in ("SLURM_PROCID", "SLURM_NTASKS", "OMPI_COMM_WORLD_RANK",
                 "OMPI_COMM_WORLD_SIZE"):
        monkeypatch.delenv(name, raising=False)
    assert data_parallel.cluster_process() == (0, 1)
    monkeypatch.setenv("SLURM_PROCID", "3")
    monkeypatch.setenv("SLURM_NTASKS", "4")
    assert data_parallel.cluster_process() == (3, 4)
    assert data_parallel.cluster_process(1, 2) == (1, 2)
    with pytest.raises(ValueError, match=r"process_id must be in \[0, 2\), got 3"):
        data_parallel.cluster_process(num_processes=2)


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
