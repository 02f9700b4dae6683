"""Training runs on the simulator: build, resume, train, log, checkpoint and evaluate.

    result = train(TrainConfig(map_name="MoveToBeacon", agent="atari", ...), "/tmp/run")

A run directory holds:
  config.json          the resolved `TrainConfig`
  checkpoints/         Orbax checkpoints of the whole `TrainState` (learner and actors)
  metrics.csv          one row per chunk of updates (`step` = agent steps so far)
  tensorboard/         the same scalars as TensorBoard event files
  episodes.csv         every finished training episode: step and score
  learning_curve.png   the mean episode score against agent steps
  eval.json            the final evaluation (mean, std, max, every score)

Running `train` again on a directory with a checkpoint resumes from it: the learner,
the optimiser, the environments and every PRNG key continue where the checkpoint left
them, and log rows written after it are dropped, so nothing past the last checkpoint
is lost and nothing is counted twice.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import time
from collections.abc import Callable
from typing import Any

import jax
import numpy as np

from sc2jax.environment.environments import simulator
from sc2jax.environment.simulator import Simulator
from sc2jax.experiments import evaluation
from sc2jax.experiments.actor import ActorCore, actor_core, make_unroll
from sc2jax.experiments.checkpoints import Checkpointer, write_json_atomic
from sc2jax.experiments.compiled_loop import TrainState, make_train_chunk
from sc2jax.experiments.config import TrainConfig
from sc2jax.experiments.learner import Learner, OptimiserConfig, make_learner
from sc2jax.experiments.metrics_log import CsvLog, Progress, read_csv
from sc2jax.experiments.plots import plot_learning_curves
from sc2jax.experiments.tensorboard import SummaryWriter
from sc2jax.losses.learner_loss import make_actor_critic_loss
from sc2jax.networks.factory import make_network

SCORE_WINDOW = 100
"""Episodes averaged for the reported recent score."""


@dataclasses.dataclass(frozen=True)
class Agent:
    """Everything built from a config: simulator, network, actor and learner."""

    config: TrainConfig
    sim: Simulator
    network: Any
    core: ActorCore
    learner: Learner

    def initial_state(self, key: jax.Array, learning_rate: Any = None) -> TrainState:
        """A fresh run: new parameters, optimiser state and environments."""
        learner_key, actor_key = jax.random.split(key)
        actor = self._reset_actors(actor_key)
        rate = self.config.learning_rate if learning_rate is None else learning_rate
        learner = self.learner.init(learner_key, actor.timestep.observation, rate)
        return TrainState(learner, actor)

    @functools.cached_property
    def _reset_actors(self):
        """key -> the actors' first state, compiled (run op by op, the resets take several
        times longer than compiling them). The network is initialised op by op: compiled,
        its initial weights would differ in the last bits."""
        unroll = make_unroll(self.sim, self.core, self.config.unroll_length)
        return jax.jit(lambda key: unroll.init(key, self.config.num_envs))

    def chunk(self, num_runs: int | None = None):
        """The compiled chunk (`make_train_chunk`), built once per agent and run count."""
        if num_runs not in self._chunks:
            unroll = make_unroll(self.sim, self.core, self.config.unroll_length)
            self._chunks[num_runs] = make_train_chunk(
                unroll, self.learner, self.config.updates_per_chunk, num_runs=num_runs)
        return self._chunks[num_runs]

    @functools.cached_property
    def _chunks(self) -> dict:
        return {}


@functools.cache
def build(config: TrainConfig) -> Agent:
    """Builds the simulator, network, actor and learner of a config (once per config, so
    runs of the same config in one process share compiled code)."""
    sim = simulator(config.map_name, config.observation_format(), config.step_mul, 0, 1.0,
                    float(config.discount), False)
    network = make_network(config.agent, sim.fmt)
    loss = make_actor_critic_loss(
        network, value_weight=config.value_weight, entropy_weight=config.entropy_weight,
        off_policy_correction=config.off_policy_correction)
    optimiser = OptimiserConfig(decay=config.rmsprop_decay, epsilon=config.rmsprop_epsilon,
                                max_grad_norm=config.max_grad_norm,
                                anneal_updates=config.total_updates,
                                warmup_updates=config.warmup_updates)
    return Agent(config, sim, network, actor_core(network, functions=config.functions),
                 make_learner(network, loss, optimiser))


@dataclasses.dataclass(frozen=True)
class TrainResult:
    """What a finished run gives back.

    Attributes:
      state: the final `TrainState`.
      episode_steps, episode_scores: every training episode's end step and score.
      evaluation: the final evaluation's summary (None without one).
      seconds: wall-clock seconds of this call (compilation included).
    """

    state: TrainState
    episode_steps: np.ndarray
    episode_scores: np.ndarray
    evaluation: dict | None
    seconds: float


def _episode_rows(episodes, first_step: int, steps_per_update: int, k: int):
    """(end step, score) of every episode that ended in a chunk; leaves [U, K, B]."""
    ended = np.asarray(episodes.ended)
    u, t, _ = np.nonzero(ended)
    steps = first_step + u * steps_per_update + (t + 1) * (steps_per_update // k)
    return steps, np.asarray(episodes.score)[ended]


def check_run_dir(run_dir: str, config: TrainConfig) -> None:
    """Raises ValueError if `run_dir` holds a run whose config differs from `config` in
    anything but `total_steps`."""
    path = os.path.join(run_dir, "config.json")
    if os.path.exists(path):
        with open(path) as f:
            saved = TrainConfig.from_json(json.load(f))
        if saved != config:
            diff = {k: (v, getattr(config, k)) for k, v in saved.to_json().items()
                    if getattr(config, k) != v and k != "total_steps"}
            if diff:
                raise ValueError(f"{run_dir} holds a run with another config; differences "
                                 f"(saved, given): {diff}. Use a new directory.")


def train(config: TrainConfig, run_dir: str, *, log: Callable[[str], None] = print,
          progress: bool = True, stop_after_updates: int | None = None) -> TrainResult:
    """Trains (or resumes) a run in `run_dir`, then evaluates it.

    Args:
      config: the run. A resumed run may only change `total_steps`.
      run_dir: the run's directory (created if needed).
      log: where status lines go.
      progress: show a progress bar on stderr.
      stop_after_updates: stop (with a checkpoint, without evaluating) once this many
        updates are done, as a preempted job would; a later call resumes.

    Returns:
      The `TrainResult`.

    Raises:
      ValueError: if `run_dir` holds a run with a different config.
    """
    start = time.time()
    os.makedirs(run_dir, exist_ok=True)
    check_run_dir(run_dir, config)
    write_json_atomic(os.path.join(run_dir, "config.json"), config.to_json())
    agent = build(config)
    state = agent.initial_state(jax.random.PRNGKey(config.seed))
    checkpointer = Checkpointer(os.path.join(run_dir, "checkpoints"))
    update, env_steps = 0, 0
    if checkpointer.latest_step() is not None:
        state, meta = checkpointer.restore(state)
        update, env_steps = meta["update"], meta["env_steps"]
        log(f"Resumed from update {update} ({env_steps} agent steps)")
    resume = env_steps if update else None
    metrics_log = CsvLog(os.path.join(run_dir, "metrics.csv"), resume_step=resume)
    episode_log = CsvLog(os.path.join(run_dir, "episodes.csv"), ("step", "score"),
                         resume_step=resume)
    writer = SummaryWriter(os.path.join(run_dir, "tensorboard"))
    bar = Progress(config.total_updates * config.steps_per_update,
                   show=("score", "score_max", "entropy")) if progress else None
    recent = list(read_csv(episode_log.path)["score"][-SCORE_WINDOW:]) if resume else []
    chunk = agent.chunk()
    last_save = time.time()
    log(f"Training {config.agent} on {config.map_name}: {config.total_updates} updates of "
        f"{config.num_envs} environments x {config.unroll_length} steps "
        f"(the first chunk compiles)")
    stop_at = config.total_updates if stop_after_updates is None else min(
        stop_after_updates, config.total_updates)
    try:
        while update < stop_at:
            chunk_start = time.time()
            state, metrics, episodes = chunk(state)
            metrics, episodes = jax.device_get((metrics, episodes))
            steps, scores = _episode_rows(episodes, env_steps, config.steps_per_update,
                                          config.unroll_length)
            update += config.updates_per_chunk
            env_steps += config.updates_per_chunk * config.steps_per_update
            for step, score in zip(steps, scores):
                episode_log.write({"step": int(step), "score": float(score)})
            recent = (recent + scores.tolist())[-SCORE_WINDOW:]
            row = {"step": env_steps, "update": update, "wall_time": time.time() - start,
                   "steps_per_s": config.updates_per_chunk * config.steps_per_update
                   / (time.time() - chunk_start),
                   "episodes": int(scores.size),
                   "score": float(np.mean(recent)) if recent else float("nan"),
                   "score_max": float(np.max(recent)) if recent else float("nan"),
                   **{k: float(np.mean(v)) for k, v in metrics.items()}}
            metrics_log.write(row)
            writer.scalars({k: v for k, v in row.items() if k != "step"}, env_steps)
            if bar is not None:
                bar.update(env_steps, {"score": row["score"], "score_max": row["score_max"],
                                       "entropy": row["function_entropy"]})
            if (time.time() - last_save >= config.checkpoint_interval_s
                    or update >= stop_at):
                writer.flush()
                checkpointer.save(update, state, {"update": update, "env_steps": env_steps})
                last_save = time.time()
    finally:
        if bar is not None:
            bar.close()
        writer.close()
        metrics_log.close()
        episode_log.close()
        checkpointer.close()
    episode_table = read_csv(episode_log.path)
    _plot(run_dir, config)
    summary = None
    if config.eval_episodes and update >= config.total_updates:
        log(f"Evaluating for {config.eval_episodes} episodes")
        stats = evaluate_params(agent, state.learner.params, config.eval_episodes,
                                seed=config.seed + 1)
        summary = stats.summary
        write_json_atomic(os.path.join(run_dir, "eval.json"),
                          {**summary, "scores": stats.scores.tolist(),
                           "agent_steps": env_steps, "config": config.to_json()})
    return TrainResult(state, episode_table["step"], episode_table["score"], summary,
                       time.time() - start)


def _plot(run_dir: str, config: TrainConfig) -> None:
    from sc2jax.experiments.paper import TABLE1

    table = read_csv(os.path.join(run_dir, "metrics.csv"))
    if table["step"].size == 0:
        return
    row = {"atari": "atari_net", "fullyconv": "fullyconv",
           "fullyconv_lstm": "fullyconv_lstm"}.get(config.agent)
    references = {} if row is None else {f"paper {row} best mean":
                                         TABLE1[row][config.map_name][0]}
    plot_learning_curves({"run": (table["step"], table["score"])},
                         os.path.join(run_dir, "learning_curve.png"),
                         title=f"{config.agent} on {config.map_name}", references=references)


def evaluate_params(agent: Agent, params: Any, episodes: int, *, num_envs: int = 64,
                    seed: int = 0, temperature: float = 1.0) -> evaluation.EpisodeStats:
    """Runs `episodes` episodes of a trained network (sampling at `temperature`)."""
    core = agent.core if temperature == 1.0 else actor_core(
        agent.network, temperature, agent.config.functions)
    return evaluation.run_core_episodes(agent.sim, core, params, episodes, num_envs, seed)


def load_run(run_dir: str, step: int | None = None) -> tuple[Agent, Any, dict]:
    """The agent, trained parameters and checkpoint metadata of a run directory.

    Raises:
      FileNotFoundError: if `run_dir` has no config.json or no checkpoint.
    """
    path = os.path.join(run_dir, "config.json")
    if not os.path.exists(path):
        raise FileNotFoundError(f"{run_dir} is not a run directory (no config.json)")
    with open(path) as f:
        config = TrainConfig.from_json(json.load(f))
    agent = build(config)
    target = jax.eval_shape(lambda: agent.initial_state(jax.random.PRNGKey(0)))
    with Checkpointer(os.path.join(run_dir, "checkpoints")) as checkpointer:
        state, meta = checkpointer.restore(target, step)
    return agent, state.learner.params, meta
