"""Hyper-parameter sweeps like the paper's: R runs trained together.

Every run shares the config but has its own seed and its own initial learning rate,
sampled log-uniformly from [lr_min, lr_max] (the paper: [1e-5, 1e-3]). The R runs'
states are stacked on a leading axis and one chunk advances them all: vmapped inside
one compiled program on an accelerator, one run's step after another on CPU
(`compiled_loop.make_train_chunk`). A sweep directory holds:

  config.json, sweep.json   the shared config; the rates and the Table 1 summary
  checkpoints/              the stacked state (a sweep resumes like a run)
  best/                     with `best_eval_interval`: each run's best parameters by
                            periodic evaluation, stacked (saved with the checkpoints)
  curves.csv                run, step, recent mean score, one row per run per chunk
  learning_curves.png       every run faint, the best run solid (the paper's Figure 6)

A sweep may be split over several processes or hosts (`part`): each trains a contiguous
block of the runs in its own sweep directory, ``part<i>of<n>/``, with no traffic between
them, and the last to finish writes the whole sweep's sweep.json, curves.csv and plot
from every part's (parts that finish together each write the same files, atomically). A
part resumes from its own checkpoints, so a sweep resumes after losing a host when it is
started again with the same number of parts.

A run's score is the mean of its final evaluation (`eval_episodes` episodes) of its
final parameters, or, with `best_eval_interval`, of its best parameters by periodic
evaluation (as `train` chooses them; the final parameters' scores are kept too). Without
a final evaluation it is the mean of the run's last `SCORE_WINDOW` training episodes.
The Table 1 summary gives the mean of those over runs, the best run's, and the highest
single episode score seen.
"""

from __future__ import annotations

import json
import os
import re
import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.atomic import atomic_write, write_json_atomic
from sc2jax.checks import check_positive_int
from sc2jax.experiments.reporting.metrics_log import CsvLog, read_csv
from sc2jax.experiments.reporting.plots import plot_learning_curves
from sc2jax.experiments.training.checkpoints import (
    Checkpointer,
    placed_as_restored,
)
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.trainer import (
    SCORE_WINDOW,
    best_eval_due,
    best_eval_score,
    build,
    check_run_dir,
    evaluate_params,
    has_checkpoint,
    start_params,
    with_params,
)


def sample_learning_rates(key: jax.Array, num_runs: int, lr_min: float = 1e-5,
                          lr_max: float = 1e-3) -> np.ndarray:
    """float32[num_runs] learning rates, log-uniform in [lr_min, lr_max].

    Raises:
      ValueError: unless 0 < lr_min <= lr_max and num_runs >= 1.
    """
    check_positive_int("num_runs", num_runs)
    if not 0 < lr_min <= lr_max:
        raise ValueError(f"need 0 < lr_min <= lr_max, got lr_min={lr_min!r}, "
                         f"lr_max={lr_max!r}")
    u = jax.random.uniform(key, (num_runs,))
    return np.asarray(jnp.exp(jnp.log(lr_min) + u * (jnp.log(lr_max) - jnp.log(lr_min))),
                      np.float32)


def run_sweep(config: TrainConfig, learning_rates, sweep_dir: str, *,
              log: Callable[[str], None] = print, part: tuple[int, int] = (0, 1)) -> dict:
    """Trains len(learning_rates) runs together, evaluates each and summarises.

    Args:
      config: the shared config (run r uses seed `config.seed + r`).
      learning_rates: float[R] the runs' initial learning rates.
      sweep_dir: the sweep's directory; an existing sweep there is resumed.
      log: where status lines go.
      part: (i, n): train only the i-th of n contiguous blocks of the runs (n <= R), in
        sweep_dir/part<i>of<n>, as process i of n; the last part to finish writes the
        whole sweep's summary.

    Returns:
      The summary written to sweep.json: `learning_rates`, the `runs` it covers, per-run
      `run_scores` and `run_max`, and `mean_over_runs`, `best_run`, `best_mean`, `max`
      (NaN scores and a `best_run` of None when no run has finished an episode). With
      `best_eval_interval` also per run `best_eval_scores` and `best_updates` (the
      periodic evaluation that chose its best parameters, and when), and with a final
      evaluation `final_scores` (its final parameters'). Of one part, while other parts
      are still training: that part's summary, with `complete` False.

    Raises:
      ValueError: for bad learning rates, a config not on the simulator or with an
        `actor_device`, a bad part, or a sweep directory split into another number of
        parts.
    """
    if config.backend != "simulator":
        raise ValueError(f"a sweep trains its runs together in one compiled program on the "
                         f"simulator; backend {config.backend!r} is not allowed (on the real "
                         f"game, train each learning rate with train --backend=sc2)")
    if config.actor_device is not None:
        raise ValueError(f"a sweep trains its runs in one compiled program; "
                         f"actor_device={config.actor_device} is for train; leave it unset")
    rates = np.asarray(learning_rates, np.float32)
    if rates.ndim != 1 or rates.size < 1 or not (rates > 0).all():
        raise ValueError(f"learning_rates must be a non-empty list of positive rates, got "
                         f"{learning_rates!r}")
    index, parts = part
    if not (isinstance(parts, int) and 1 <= parts <= rates.size and 0 <= index < parts):
        raise ValueError(f"part must be (i, n) with 0 <= i < n <= {rates.size} (the runs), "
                         f"got {part!r}")
    if parts == 1:
        return _sweep(config, rates, np.arange(rates.size), sweep_dir, log)
    check_run_dir(sweep_dir, config)
    others = sorted(name for name in (os.listdir(sweep_dir) if os.path.isdir(sweep_dir)
                                      else ()) if re.fullmatch(r"part\d+of\d+", name)
                    and not re.fullmatch(rf"part\d+of{parts}", name))
    if others:
        raise ValueError(f"{sweep_dir} was split into other parts ({', '.join(others)}); "
                         f"resume it with as many processes, or use a new directory")
    os.makedirs(sweep_dir, exist_ok=True)
    write_json_atomic(os.path.join(sweep_dir, "config.json"), config.to_json())
    blocks = np.array_split(np.arange(rates.size), parts)
    mine = _sweep(config, rates[blocks[index]], blocks[index],
                  os.path.join(sweep_dir, f"part{index}of{parts}"), log)
    summaries = [read_summary(os.path.join(sweep_dir, f"part{i}of{parts}"))
                 for i in range(parts)]
    if not all(s is not None and s["agent_steps_per_run"] == mine["agent_steps_per_run"]
               for s in summaries):
        log(f"Part {index} of {parts} is done; the last part to finish writes the sweep's "
            f"summary")
        return {**mine, "complete": False}
    return _merge(config, summaries, sweep_dir)


def read_summary(part_dir: str) -> dict | None:
    """A finished sweep's (or part's) sweep.json; None before it has one."""
    path = os.path.join(part_dir, "sweep.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def _merge(config: TrainConfig, parts: list[dict], sweep_dir: str) -> dict:
    """The whole sweep's summary, curves and plot from its parts' (in run order)."""
    joined = {key: [v for p in parts for v in p[key]] for key in parts[0]
              if key in _PER_RUN}
    summary = _summary(config, joined.pop("learning_rates"), joined.pop("runs"),
                       joined.pop("run_scores"), joined.pop("run_max"), joined,
                       parts[0]["agent_steps_per_run"], max(p["seconds"] for p in parts))
    write_json_atomic(os.path.join(sweep_dir, "sweep.json"), summary)
    lines = []
    for i in range(len(parts)):
        with open(os.path.join(sweep_dir, f"part{i}of{len(parts)}", "curves.csv")) as f:
            header, *rows = f.read().splitlines(keepends=True)
        lines += ([header] if not lines else []) + rows
    with atomic_write(os.path.join(sweep_dir, "curves.csv")) as f:
        f.writelines(lines)
    _plot(config, summary, sweep_dir)
    return summary


_PER_RUN = ("learning_rates", "runs", "run_scores", "run_max", "best_eval_scores",
            "best_updates", "final_scores")
"""The summary's entries that hold a value per run."""


def _summary(config: TrainConfig, rates, runs, run_scores, run_max, extra: dict,
             env_steps: int, seconds: float) -> dict:
    """sweep.json's contents (`run_sweep`) from the runs' ids and per-run results."""
    scored = np.isfinite(run_scores)  # a run without a finished episode has no score
    best = int(np.nanargmax(run_scores)) if scored.any() else None
    return {"learning_rates": list(rates), "runs": list(runs), "run_scores": run_scores,
            "run_max": run_max,
            "mean_over_runs": float(np.mean(np.asarray(run_scores)[scored]))
            if scored.any() else float("nan"), "best_run": None if best is None else runs[best],
            "best_mean": run_scores[best] if best is not None else float("nan"),
            "max": float(np.max(run_max)),
            "agent_steps_per_run": env_steps, "seconds": seconds,
            **extra, "config": config.to_json()}


def _plot(config: TrainConfig, summary: dict, sweep_dir: str) -> None:
    """learning_curves.png from sweep_dir/curves.csv."""
    table = read_csv(os.path.join(sweep_dir, "curves.csv"))
    curves = {f"run {r} (lr {rate:.1e})": (table["step"][table["run"] == r],
                                           table["score"][table["run"] == r])
              for r, rate in zip(summary["runs"], summary["learning_rates"])}
    plot_learning_curves(curves, os.path.join(sweep_dir, "learning_curves.png"),
                         title=f"{config.agent} on {config.map_name}: {len(curves)} runs")


def _sweep(config: TrainConfig, rates: np.ndarray, runs: np.ndarray, sweep_dir: str,
           log: Callable[[str], None]) -> dict:
    """Trains the runs `runs` (int[R] their numbers in the sweep, which give their seeds)
    with `rates` (float32[R]) in `sweep_dir`; `run_sweep`'s summary of them."""
    start = time.time()
    num_runs = int(rates.size)
    check_run_dir(sweep_dir, config)
    agent = build(config)
    initial = None if has_checkpoint(sweep_dir) else start_params(agent)
    os.makedirs(sweep_dir, exist_ok=True)
    write_json_atomic(os.path.join(sweep_dir, "config.json"), config.to_json())
    keys = jax.vmap(jax.random.PRNGKey)(config.seed + jnp.asarray(runs))
    state = placed_as_restored(jax.vmap(agent.initial_state)(keys, jnp.asarray(rates)))
    update, env_steps = 0, 0
    checkpointer = Checkpointer(os.path.join(sweep_dir, "checkpoints"))
    if checkpointer.latest_step() is not None:
        state, meta = checkpointer.restore(state)
        update, env_steps = meta["update"], meta["env_steps"]
        log(f"Resumed the sweep from update {update}")
    elif initial is not None:
        state = with_params(state, jax.tree.map(
            lambda p, x: jnp.broadcast_to(p, x.shape), initial, state.learner.params))
        log(f"Every run starts from the parameters of {config.init_from}")
    kept = _BestParams(agent, os.path.join(sweep_dir, "best"), state.learner.params, runs)
    curves = CsvLog(os.path.join(sweep_dir, "curves.csv"), ("run", "step", "score", "max"),
                    resume_step=env_steps if update else None)
    recent = [[] for _ in range(num_runs)]
    run_max = np.full(num_runs, -np.inf)
    chunk = agent.chunk(num_runs)
    last_save = time.time()
    log(f"Sweeping {num_runs} runs of {config.agent} on {config.map_name}, "
        f"{config.total_updates} updates each (the first chunk compiles)")
    try:
        while update < config.total_updates:
            state, _, episodes = chunk(state)
            ended, score = np.asarray(episodes.ended), np.asarray(episodes.score)
            update += config.updates_per_chunk
            env_steps += config.updates_per_chunk * config.steps_per_update
            if best_eval_due(config, update):
                kept.offer(state.learner.params, update)
            for r in range(num_runs):
                scores = score[r][ended[r]]
                recent[r] = (recent[r] + scores.tolist())[-SCORE_WINDOW:]
                run_max[r] = max(run_max[r], scores.max(initial=-np.inf))
                curves.write({"run": runs[r], "step": env_steps,
                              "score": float(np.mean(recent[r])) if recent[r] else None,
                              "max": float(run_max[r]) if np.isfinite(run_max[r]) else None})
            if (time.time() - last_save >= config.checkpoint_interval_s
                    or update >= config.total_updates):
                kept.save()  # First, as in `train`.
                checkpointer.save(update, state, {"update": update, "env_steps": env_steps})
                last_save = time.time()
            best = max((np.mean(r) for r in recent if r), default=float("nan"))
            log(f"  {env_steps} steps per run, best recent mean {best:.2f} "
                f"[{time.time() - start:.0f} s]")
    finally:
        curves.close()
        checkpointer.close()
        kept.close()
    table = read_csv(os.path.join(sweep_dir, "curves.csv"))
    run_scores, run_max, final_scores = [], [], []
    for r in range(num_runs):
        mine = table["run"] == r
        run_max.append(float(np.nanmax(table["max"][mine], initial=-np.inf)))
        if not config.eval_episodes:
            run_scores.append(float(table["score"][mine][-1]) if mine.any() else float("nan"))
            continue
        for params in (state.learner.params, kept.params):
            if params is None:
                continue
            stats = evaluate_params(agent, _run(params, r), config.eval_episodes,
                                    seed=config.seed + int(runs[r]))
            run_max[-1] = max(run_max[-1], stats.summary["max"])
            if params is state.learner.params:
                final_scores.append(stats.summary["mean"])
        run_scores.append(stats.summary["mean"])  # The best parameters' where kept.
    extra = {}
    if kept.params is not None:
        extra = {"best_eval_scores": kept.scores.tolist(), "best_updates": kept.updates.tolist()}
        if final_scores:
            extra["final_scores"] = final_scores
    summary = _summary(config, rates.tolist(), runs.tolist(), run_scores, run_max, extra,
                       env_steps, time.time() - start)
    write_json_atomic(os.path.join(sweep_dir, "sweep.json"), summary)
    _plot(config, summary, sweep_dir)
    return summary


def run_score_rule(config: TrainConfig) -> str:
    """In words, what a run's score in a sweep of `config` is."""
    if not config.eval_episodes:
        return f"the mean of its last {SCORE_WINDOW} training episodes"
    which = ("its final parameters" if not config.best_eval_interval else
             f"its best parameters by an evaluation of {config.best_eval_episodes} "
             f"episodes every {config.best_eval_interval} updates")
    return f"the mean of {config.eval_episodes} fresh evaluation episodes of {which}"


def _run(stacked: Any, r: int) -> Any:
    """Run r's slice of a pytree stacked over runs."""
    return jax.tree.map(lambda x: x[r], stacked)


class _BestParams:
    """Each run's best parameters by periodic evaluation (`best_eval_interval`), kept
    stacked in `directory` (made at the first save) and restored from it on a resume.

    Attributes:
      params: the stacked best parameters, or None before the first evaluation.
      scores: float[R] the evaluation means that chose them.
      updates: int[R] the updates at which they were evaluated.
    """

    def __init__(self, agent, directory: str, like: Any, runs: np.ndarray):
        self._agent, self._directory, self._runs = agent, directory, runs
        self.params = self.scores = self.updates = None
        self._checkpointer, self._unsaved = None, False
        if agent.config.best_eval_interval and os.path.isdir(directory):
            self._checkpointer = Checkpointer(directory, max_to_keep=1)
            if self._checkpointer.latest_step() is not None:
                self.params, meta = self._checkpointer.restore(like)
                self.scores = np.asarray(meta["scores"], np.float64)
                self.updates = np.asarray(meta["updates"], np.int64)

    def offer(self, stacked: Any, update: int) -> None:
        """Evaluates every run's current parameters and keeps those that beat its best."""
        config = self._agent.config
        runs = jax.tree.leaves(stacked)[0].shape[0]
        scores = np.array([best_eval_score(self._agent, _run(stacked, r),
                                           config.seed + int(self._runs[r]))
                           for r in range(runs)])
        stacked = jax.device_get(stacked)
        if self.params is None:
            self.params, self.scores = stacked, scores
            self.updates = np.full(runs, update, np.int64)
        else:
            better = scores > self.scores
            self.params = jax.tree.map(
                lambda new, old: np.where(better.reshape((-1,) + (1,) * (new.ndim - 1)),
                                          new, old), stacked, self.params)
            self.scores = np.where(better, scores, self.scores)
            self.updates = np.where(better, update, self.updates)
        self._unsaved = True

    def save(self) -> None:
        if not self._unsaved:
            return
        if self._checkpointer is None:
            self._checkpointer = Checkpointer(self._directory, max_to_keep=1)
        self._checkpointer.save(int(self.updates.max()), self.params,
                                {"scores": self.scores.tolist(),
                                 "updates": self.updates.tolist()})
        self._unsaved = False

    def close(self) -> None:
        if self._checkpointer is not None:
            self._checkpointer.close()
