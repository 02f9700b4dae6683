"""Table 1 for sc2jax: a sweep and the random policy on each mini-game, beside the
paper's rows (the library of `python -m sc2jax.experiments.table1`).

`build_table1` runs (or resumes) the sweeps in RUN_DIR/MAP and writes RUN_DIR/table1.md
and RUN_DIR/table1.json. Nothing finished is done again: a map whose sweep finished
(its sweep.json) with at least the config's total steps is not trained again, an
unfinished sweep resumes from its checkpoint (or trains on to a larger total), and a
measured random policy is kept in RUN_DIR/MAP/random_policy.json.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Callable, Sequence

import numpy as np

from sc2jax.atomic import atomic_write, write_json_atomic
from sc2jax.environment import make
from sc2jax.experiments.reporting.paper import MAPS, NETWORK_ROW, ROW_TITLES, TABLE1
from sc2jax.experiments.sweeps.sweeping import read_summary, run_score_rule, run_sweep
from sc2jax.experiments.training import evaluation
from sc2jax.experiments.training.config import TrainConfig, parse_names
from sc2jax.experiments.training.trainer import check_run_dir

PAPER_COLUMNS = ("random_policy", "deepmind_human", "grandmaster")


def check_maps(names: Sequence[str], what: str = "maps") -> tuple[str, ...]:
    """`names` as a tuple, if they are distinct names from `paper.MAPS` (at least one).

    Raises:
      ValueError: naming `what` and the unknown names, if any.
    """
    names = tuple(names)
    unknown = [m for m in names if m not in MAPS]
    if unknown or not names or len(set(names)) != len(names):
        raise ValueError(f"{what} must be distinct names from {list(MAPS)}, got "
                         f"{list(names)}" + (f"; unknown: {unknown}" if unknown else ""))
    return names


def parse_maps(value: str) -> tuple[str, ...]:
    """The maps of a --maps value: 'all' (the seven), or comma-separated names."""
    names = parse_names(value)
    return MAPS if names is None else check_maps(names, f"--maps={value!r}")


def random_policy(config: TrainConfig, episodes: int, path: str) -> dict:
    """The paper's random policy on `config`'s map, resolution and step_mul: the summary
    of `evaluation.EpisodeStats` (episodes, mean, std, max), read from `path` if it was
    measured before with the same settings, else measured and written there."""
    settings = {"map": config.map_name, "screen_size": config.screen_size,
                "minimap_size": config.minimap_size, "step_mul": config.step_mul,
                "episodes": episodes, "seed": config.seed}
    if os.path.exists(path):
        with open(path) as f:
            saved = json.load(f)
        if saved["settings"] == settings:
            return saved["summary"]
    sim = make(config.map_name, screen_size=config.screen_size,
               minimap_size=config.minimap_size, step_mul=config.step_mul).simulator
    policy = evaluation.make_policy("random", config.map_name, sim.fmt)
    stats = evaluation.run_episodes(sim, policy, episodes, min(64, episodes), config.seed)
    write_json_atomic(path, {"settings": settings, "summary": stats.summary,
                             "scores": stats.scores.tolist()})
    return stats.summary


def build_table1(config: TrainConfig, maps: Sequence[str], learning_rates, run_dir: str,
                 random_episodes: int, *, log: Callable[[str], None] = print,
                 part: tuple[int, int] = (0, 1)) -> dict | None:
    """Runs (or reads) a sweep and the random policy on each map; writes the table.

    Args:
      config: the sweeps' shared config (its `map_name` is replaced by each map's).
      maps: names from `paper.MAPS`.
      learning_rates: float[R] the runs' rates, the same on every map.
      run_dir: the table's directory: a sweep directory per map, table1.md, table1.json.
      random_episodes: the random policy's episodes per map; 0 leaves it out.
      part: (i, n): this process trains the i-th of n parts of every map's sweep
        (`run_sweep`); the last process to finish writes the table.

    Returns:
      What table1.json holds: `maps` (per map: the sweep's summary as `run_sweep` returns
      it, and `random_policy`, a summary or None), `agent`, `learning_rates`. None for a
      process that finished before the others (the table awaits their parts).

    Raises:
      ValueError: for a run directory whose config differs, or a bad argument.
    """
    if random_episodes < 0:
        raise ValueError(f"random_episodes must be >= 0, got {random_episodes!r}")
    maps = check_maps(maps)
    rates = np.asarray(learning_rates, np.float32)
    finished = {}
    for name in maps:  # Every map's directory is checked before anything runs.
        sweep_dir = os.path.join(run_dir, name)
        check_run_dir(sweep_dir, dataclasses.replace(config, map_name=name))
        summary = read_summary(sweep_dir)
        if summary is not None:
            finished[name] = summary
            saved = np.asarray(finished[name]["learning_rates"], np.float32)
            if saved.shape != rates.shape or not np.allclose(saved, rates, rtol=1e-6):
                raise ValueError(f"{sweep_dir} holds a sweep of the learning rates "
                                 f"{saved.tolist()}, not {rates.tolist()}. Use a new "
                                 f"directory.")
    needed = config.total_updates * config.steps_per_update
    sweeps = {}
    for name in maps:
        summary = finished.get(name)
        if summary is not None and summary["agent_steps_per_run"] >= needed:
            log(f"{name}: the sweep is done ({summary['agent_steps_per_run']} agent steps per "
                f"run)")
        else:
            summary = run_sweep(dataclasses.replace(config, map_name=name), rates,
                                os.path.join(run_dir, name), log=log, part=part)
        sweeps[name] = summary
    for name in maps:  # Parts that other processes trained: merged by the last of them.
        if not sweeps[name].get("complete", True):
            merged = _finished_sweep(os.path.join(run_dir, name), needed, rates.size)
            if merged is None:
                log(f"{name}: other processes still train their parts; the last to finish "
                    f"writes the table")
                return None
            sweeps[name] = merged
    entries = {}
    for name in maps:
        map_config = dataclasses.replace(config, map_name=name)
        sweep_dir = os.path.join(run_dir, name)
        random_row = None
        if random_episodes:
            log(f"{name}: the random policy, {random_episodes} episodes")
            random_row = random_policy(map_config, random_episodes,
                                       os.path.join(sweep_dir, "random_policy.json"))
        entries[name] = {"sweep": sweeps[name], "random_policy": random_row}
    table = {"agent": config.agent, "learning_rates": rates.tolist(),
             "run_score": run_score_rule(config), "maps": entries}
    write_json_atomic(os.path.join(run_dir, "table1.json"), table)
    with atomic_write(os.path.join(run_dir, "table1.md")) as f:
        f.write(table1_markdown(table))
    return table


def _finished_sweep(sweep_dir: str, needed: int, runs: int) -> dict | None:
    """sweep_dir's sweep.json when it covers `runs` runs of `needed` agent steps."""
    summary = read_summary(sweep_dir)
    if summary is None or summary["agent_steps_per_run"] < needed or len(
            summary["run_scores"]) != runs:
        return None
    return summary


def _number(x, fmt: str) -> str:
    """x formatted, or "–" where there is none (a run without a finished episode)."""
    return "–" if x is None or not np.isfinite(x) else format(x, fmt)


def _paper(row: str, name: str) -> str:
    mean, best = TABLE1[row][name]
    return f"{mean:g} ({best:g})"


def table1_markdown(table: dict) -> str:
    """Table 1's rows for sc2jax beside the paper's, as a markdown table.

    Args:
      table: what `build_table1` returns.
    """
    agent = table["agent"]
    paper_agent = NETWORK_ROW.get(agent)
    header = (["Map", "sc2jax random policy mean (max)", f"sc2jax {agent}: mean over runs",
               "best mean", "max", "agent steps per run"]
              + [f"paper {ROW_TITLES[row]} mean (max)" for row in PAPER_COLUMNS[:1]]
              + ([f"paper {ROW_TITLES[paper_agent]} best mean (max)"] if paper_agent else [])
              + [f"paper {ROW_TITLES[row]} mean (max)" for row in PAPER_COLUMNS[1:]])
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for name, entry in table["maps"].items():
        sweep, random_row = entry["sweep"], entry["random_policy"]
        paper = [_paper(row, name) for row in PAPER_COLUMNS]
        random_cell = (f"{_number(random_row['mean'], '.2f')} "
                       f"({_number(random_row['max'], 'g')})" if random_row else "–")
        lines.append("| " + " | ".join(
            [name, random_cell, _number(sweep["mean_over_runs"], ".2f"),
             _number(sweep["best_mean"], ".2f"), _number(sweep["max"], "g"),
             f"{sweep['agent_steps_per_run']:,}", paper[0]]
            + ([_paper(paper_agent, name)] if paper_agent else []) + paper[1:]) + " |")
    runs = len(table["learning_rates"])
    rates = table["learning_rates"]
    rule = f" A run's score is {table['run_score']}." if "run_score" in table else ""
    return (f"Table 1 for sc2jax: {agent}, {runs} runs per map, learning rates "
            f"{min(rates):.2e}–{max(rates):.2e}.{rule}\n\n" + "\n".join(lines) + "\n")
