"""Table 1 for sc2jax (`tables`): the maps flag, the markdown, and a table that resumes.

The sweeps themselves are tested in test_training.py; here `run_sweep` is replaced by a
stand-in that writes what a finished sweep writes, so that these tests check what
`tables` adds: one sweep directory per map, nothing finished done again, and the table.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest

from sc2jax.atomic import write_json_atomic
from sc2jax.experiments.reporting.paper import MAPS
from sc2jax.experiments.sweeps import tables
from sc2jax.experiments.training.config import TrainConfig

CONFIG = TrainConfig(agent="fullyconv", screen_size=16, minimap_size=16, num_envs=2,
                     unroll_length=4, total_steps=32, eval_episodes=0)
RATES = np.array([1e-4, 1e-3], np.float32)


def test_parse_maps():
    assert tables.parse_maps("all") == MAPS
    assert tables.parse_maps("DefeatRoaches, MoveToBeacon") == ("DefeatRoaches",
                                                                "MoveToBeacon")
    with pytest.raises(ValueError, match=r"unknown: \['Nope'\]"):
        tables.parse_maps("MoveToBeacon,Nope")
    with pytest.raises(ValueError, match="distinct"):
        tables.parse_maps("MoveToBeacon,MoveToBeacon")
    with pytest.raises(ValueError, match=r"maps must be distinct.*unknown: \['Nope'\]"):
        tables.build_table1(CONFIG, ("Nope",), RATES, "unused", 0)


def _summary(steps: int, scores=(1.5, 3.0)) -> dict:
    scored = np.isfinite(scores)
    best = int(np.nanargmax(scores)) if scored.any() else None
    return {"learning_rates": RATES.tolist(), "run_scores": list(scores),
            "run_max": [4.0, 7.0],
            "mean_over_runs": float(np.mean(np.asarray(scores)[scored])) if best is not None
            else math.nan,
            "best_run": best, "best_mean": scores[best] if best is not None else math.nan,
            "max": 7.0, "agent_steps_per_run": steps, "seconds": 1.0}


def test_markdown_puts_the_papers_rows_beside_ours():
    table = {"agent": "fullyconv", "learning_rates": RATES.tolist(), "maps": {
        "MoveToBeacon": {"sweep": _summary(64), "random_policy": {
            "episodes": 4, "mean": 0.5, "std": 0.5, "max": 1.0}},
        "DefeatRoaches": {"sweep": _summary(64, (math.nan, math.nan)),
                          "random_policy": None}}}
    lines = tables.table1_markdown(table).splitlines()
    assert "1.00e-04–1.00e-03" in lines[0] and "2 runs per map" in lines[0]
    header, beacon, roaches = lines[2], lines[4], lines[5]
    assert "paper FullyConv best mean (max)" in header
    # Ours: random 0.50 (1); mean over runs 2.25, best 3.00, max 7; the paper's random
    # policy 1 (6), FullyConv 26 (45), human 26 (28), GrandMaster 28 (28).
    assert beacon.split(" | ")[1:] == ["0.50 (1)", "2.25", "3.00", "7", "64", "1 (6)",
                                       "26 (45)", "26 (28)", "28 (28) |"]
    assert roaches.split(" | ")[1:4] == ["–", "–", "–"]
    # arFullyConv has no row in the paper's table: one paper column fewer.
    assert header.count("| paper ") == 4
    other = tables.table1_markdown({**table, "agent": "arfullyconv"}).splitlines()
    assert other[2].count("| paper ") == 3 and len(other[4].split(" | ")) == 9


@pytest.fixture
def fake_sweeps(monkeypatch):
    """Replaces `run_sweep` with a stand-in that records its calls and writes a
    finished sweep's config.json and sweep.json."""
    calls = []

    def run_sweep(config, rates, sweep_dir, log, part):
        assert part == (0, 1)
        calls.append((config.map_name, config.total_steps))
        write_json_atomic(os.path.join(sweep_dir, "config.json"), config.to_json())
        summary = _summary(config.total_updates * config.steps_per_update)
        write_json_atomic(os.path.join(sweep_dir, "sweep.json"), summary)
        return summary

    monkeypatch.setattr(tables, "run_sweep", run_sweep)
    return calls


@pytest.mark.slow
def test_table_runs_each_map_once_and_resumes(tmp_path, fake_sweeps, monkeypatch):
    maps = ("MoveToBeacon", "CollectMineralShards")
    table = tables.build_table1(CONFIG, maps, RATES, str(tmp_path), 2, log=lambda _: None)
    assert fake_sweeps == [("MoveToBeacon", 32), ("CollectMineralShards", 32)]
    for name in maps:
        random = table["maps"][name]["random_policy"]
        assert random["episodes"] == 2 and random["max"] >= random["mean"]
        assert os.path.exists(tmp_path / name / "random_policy.json")
    with open(tmp_path / "table1.json") as f:
        assert json.load(f)["maps"].keys() == set(maps)
    assert (tmp_path / "table1.md").read_text() == tables.table1_markdown(table)
    assert "A run's score is the mean of its last 100 training episodes." in (
        tmp_path / "table1.md").read_text()

    # Again: nothing is trained or measured again.
    def measured(*_):
        raise AssertionError("the random policy was measured again")
    monkeypatch.setattr(tables.evaluation, "run_episodes", measured)
    again = tables.build_table1(CONFIG, maps, RATES, str(tmp_path), 2, log=lambda _: None)
    assert len(fake_sweeps) == 2 and again == table

    # More steps: the sweeps train on (run_sweep resumes them), the random policy stays.
    more = TrainConfig(**{**CONFIG.to_json(), "total_steps": 64})
    tables.build_table1(more, maps[:1], RATES, str(tmp_path), 2, log=lambda _: None)
    assert fake_sweeps[2:] == [("MoveToBeacon", 64)]


def test_table_refuses_another_sweep_before_running_anything(tmp_path, fake_sweeps):
    tables.build_table1(CONFIG, ("CollectMineralShards",), RATES, str(tmp_path), 0,
                        log=lambda _: None)
    with pytest.raises(ValueError, match="holds a sweep of the learning rates"):
        tables.build_table1(CONFIG, ("MoveToBeacon", "CollectMineralShards"), RATES * 2,
                            str(tmp_path), 0, log=lambda _: None)
    other = TrainConfig(**{**CONFIG.to_json(), "agent": "atari"})
    with pytest.raises(ValueError, match="another config"):
        tables.build_table1(other, ("MoveToBeacon", "CollectMineralShards"), RATES,
                            str(tmp_path), 0, log=lambda _: None)
    assert fake_sweeps == [("CollectMineralShards", 32)]  # MoveToBeacon never started.
    with pytest.raises(ValueError, match="random_episodes must be >= 0"):
        tables.build_table1(CONFIG, ("MoveToBeacon",), RATES, str(tmp_path), -1)


def test_a_table_over_processes_is_written_by_the_last_to_finish(tmp_path, monkeypatch):
    def run_sweep(config, rates, sweep_dir, log, part):
        """Part 1 finishes last and merges the sweep; part 0 finds it unmerged."""
        summary = _summary(config.total_updates * config.steps_per_update)
        if part == (1, 2):
            write_json_atomic(os.path.join(sweep_dir, "sweep.json"), summary)
            return summary
        return {**summary, "complete": False}

    monkeypatch.setattr(tables, "run_sweep", run_sweep)
    build = lambda part: tables.build_table1(  # noqa: E731
        CONFIG, ("MoveToBeacon",), RATES, str(tmp_path), 0, log=lambda _: None, part=part)
    assert build((0, 2)) is None and not (tmp_path / "table1.json").exists()
    table = build((1, 2))
    assert table["maps"]["MoveToBeacon"]["sweep"]["agent_steps_per_run"] == 32
    assert json.loads((tmp_path / "table1.json").read_text()) == table
