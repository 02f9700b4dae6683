"""Hyper-parameter sweeps like the paper's: R runs trained together.

Every run shares the config but has its own seed and its own initial learning rate,
sampled log-uniformly from [lr_min, lr_max] (the paper: [1e-5, 1e-3]). The R runs'
states are stacked on a leading axis and one chunk advances them all: vmapped inside
one compiled program on an accelerator, one run's step after another on CPU
(`compiled_loop.make_train_chunk`). A sweep directory holds:

  config.json, sweep.json   the shared config; the rates and the Table 1 summary
  checkpoints/              the stacked state (a sweep resumes like a run)
  curves.csv                run, step, recent mean score, one row per run per chunk
  learning_curves.png       every run faint, the best run solid (the paper's Figure 6)

A run's score is the mean of its final evaluation (`eval_episodes` episodes), or of
its last `SCORE_WINDOW` training episodes without one; the Table 1 summary gives the
mean of those over runs, the best run's, and the highest single episode score seen.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.experiments.checkpoints import Checkpointer, write_json_atomic
from sc2jax.experiments.checks import check_positive_int
from sc2jax.experiments.config import TrainConfig
from sc2jax.experiments.metrics_log import CsvLog, read_csv
from sc2jax.experiments.plots import plot_learning_curves
from sc2jax.experiments.trainer import SCORE_WINDOW, build, check_run_dir, evaluate_params


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
              log: Callable[[str], None] = print) -> dict:
    """Trains len(learning_rates) runs together, evaluates each and summarises.

    Args:
      config: the shared config (run r uses seed `config.seed + r`).
      learning_rates: float[R] the runs' initial learning rates.
      sweep_dir: the sweep's directory; an existing sweep there is resumed.
      log: where status lines go.

    Returns:
      The summary written to sweep.json: `learning_rates`, per-run `run_scores` and
      `run_max`, and `mean_over_runs`, `best_run`, `best_mean`, `max` (NaN scores and
      a `best_run` of None when no run has finished an episode).

    Raises:
      ValueError: for bad learning rates, or a config not on the simulator.
    """
    if config.backend != "simulator":
        raise ValueError(f"a sweep trains its runs together in one compiled program on the "
                         f"simulator; backend {config.backend!r} is not allowed (on the real "
                         f"game, train each learning rate with train --backend=sc2)")
    rates = np.asarray(learning_rates, np.float32)
    if rates.ndim != 1 or rates.size < 1 or not (rates > 0).all():
        raise ValueError(f"learning_rates must be a non-empty list of positive rates, got "
                         f"{learning_rates!r}")
    start = time.time()
    num_runs = int(rates.size)
    os.makedirs(sweep_dir, exist_ok=True)
    check_run_dir(sweep_dir, config)
    write_json_atomic(os.path.join(sweep_dir, "config.json"), config.to_json())
    agent = build(config)
    keys = jax.vmap(jax.random.PRNGKey)(config.seed + jnp.arange(num_runs))
    state = jax.vmap(agent.initial_state)(keys, jnp.asarray(rates))
    update, env_steps = 0, 0
    checkpointer = Checkpointer(os.path.join(sweep_dir, "checkpoints"))
    if checkpointer.latest_step() is not None:
        state, meta = checkpointer.restore(state)
        update, env_steps = meta["update"], meta["env_steps"]
        log(f"Resumed the sweep from update {update}")
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
            for r in range(num_runs):
                scores = score[r][ended[r]]
                recent[r] = (recent[r] + scores.tolist())[-SCORE_WINDOW:]
                run_max[r] = max(run_max[r], scores.max(initial=-np.inf))
                curves.write({"run": r, "step": env_steps,
                              "score": float(np.mean(recent[r])) if recent[r] else None,
                              "max": float(run_max[r]) if np.isfinite(run_max[r]) else None})
            if (time.time() - last_save >= config.checkpoint_interval_s
                    or update >= config.total_updates):
                checkpointer.save(update, state, {"update": update, "env_steps": env_steps})
                last_save = time.time()
            best = max((np.mean(r) for r in recent if r), default=float("nan"))
            log(f"  {env_steps} steps per run, best recent mean {best:.2f} "
                f"[{time.time() - start:.0f} s]")
    finally:
        curves.close()
        checkpointer.close()
    table = read_csv(os.path.join(sweep_dir, "curves.csv"))
    run_scores, run_max = [], []
    for r in range(num_runs):
        mine = table["run"] == r
        run_max.append(float(np.nanmax(table["max"][mine], initial=-np.inf)))
        if config.eval_episodes:
            params = jax.tree.map(lambda x, r=r: x[r], state.learner.params)
            stats = evaluate_params(agent, params, config.eval_episodes, seed=config.seed + r)
            run_scores.append(stats.summary["mean"])
            run_max[-1] = max(run_max[-1], stats.summary["max"])
        else:
            run_scores.append(float(table["score"][mine][-1]) if mine.any() else float("nan"))
    scored = np.isfinite(run_scores)  # a run without a finished episode has no score
    best = int(np.nanargmax(run_scores)) if scored.any() else None
    summary = {"learning_rates": rates.tolist(), "run_scores": run_scores, "run_max": run_max,
               "mean_over_runs": float(np.mean(np.asarray(run_scores)[scored]))
               if scored.any() else float("nan"), "best_run": best,
               "best_mean": run_scores[best] if best is not None else float("nan"),
               "max": float(np.max(run_max)),
               "agent_steps_per_run": env_steps, "seconds": time.time() - start,
               "config": config.to_json()}
    write_json_atomic(os.path.join(sweep_dir, "sweep.json"), summary)
    runs = {f"run {r} (lr {rates[r]:.1e})": (table["step"][table["run"] == r],
                                              table["score"][table["run"] == r])
            for r in range(num_runs)}
    plot_learning_curves(runs, os.path.join(sweep_dir, "learning_curves.png"),
                         title=f"{config.agent} on {config.map_name}: {num_runs} runs")
    return summary
