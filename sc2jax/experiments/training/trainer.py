"""Training runs: build, resume, train, log, checkpoint and evaluate.

    result = train(TrainConfig(map_name="MoveToBeacon", agent="atari", ...), "/tmp/run")
    result = train(TrainConfig(backend="sc2", num_envs=8, ...), "/tmp/run2")  # the game

On the simulator (backend "simulator") a chunk of updates is one compiled program:
environments, actors and learner. On the real game (backend "sc2") each environment is
a game process, stepped by a `HostActor` thread that feeds the learner (`SplitLoop`).

A run directory holds:
  config.json          the resolved `TrainConfig`
  checkpoints/         Orbax checkpoints of the whole `TrainState` (learner and actors)
  metrics.csv          one row per chunk of updates (`step` = agent steps so far)
  tensorboard/         the same scalars as TensorBoard event files
  episodes.csv         every finished training episode: step and score
  learning_curve.png   the mean episode score against agent steps
  best/                the best parameters so far (Orbax; saved with the checkpoints):
                       those of the best mean of `SCORE_WINDOW` recent training
                       episodes, or with `best_eval_interval` of the best periodic
                       evaluation
  eval.json            the final evaluation (mean, std, max, every score)
  eval_best.json       the same for the best parameters, where they are not the final

Running `train` again on a directory with a checkpoint resumes from it: the learner,
the optimiser, the environments and every PRNG key continue where the checkpoint left
them, and log rows written after it are dropped, so nothing past the last checkpoint
is lost and nothing is counted twice. (Game processes cannot be checkpointed: a resumed
run on the real game restores the learner and starts new episodes.)
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
import time
from collections.abc import Callable
from typing import Any

import dm_env
import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.atomic import write_json_atomic
from sc2jax.checks import check_positive_int
from sc2jax.environment.engine.compiled import simulator
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.engine.xla.devices import first_devices
from sc2jax.environment.interface import specs
from sc2jax.environment.sc2_env import make
from sc2jax.environment.sc2api.game_env import GameEnvBatch
from sc2jax.experiments.reporting.metrics_log import CsvLog, Progress, read_csv
from sc2jax.experiments.reporting.plots import plot_learning_curves
from sc2jax.experiments.reporting.tensorboard import SummaryWriter
from sc2jax.experiments.training import data_parallel, evaluation, pretrained
from sc2jax.experiments.training.actor import ActorCore, actor_core, make_unroll
from sc2jax.experiments.training.checkpoints import (
    Checkpointer,
    placed_as_restored,
)
from sc2jax.experiments.training.compiled_loop import TrainState, make_train_chunk
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.device_actor import DeviceActor
from sc2jax.experiments.training.host_actor import HostActor, SplitLoop
from sc2jax.experiments.training.learner import (
    Learner,
    LearnerState,
    OptimiserConfig,
    make_learner,
)
from sc2jax.losses.learner_loss import make_actor_critic_loss, make_ppo_targets
from sc2jax.networks.factory import make_network

SCORE_WINDOW = 100
"""Episodes averaged for the reported recent score (and for choosing the best
parameters, over full windows only)."""


@dataclasses.dataclass(frozen=True)
class Agent:
    """Everything built from a config: simulator (None on the real game), network,
    actor and learner. Agents whose configs differ only in `RUN_ONLY_FIELDS` share
    these parts and the programs compiled from them (`programs`)."""

    config: TrainConfig
    sim: Simulator | None
    network: Any
    core: ActorCore
    learner: Learner
    programs: dict = dataclasses.field(default_factory=dict, repr=False, compare=False)

    def initial_state(self, key: jax.Array, learning_rate: Any = None) -> TrainState:
        """A fresh run: new parameters, optimiser state and environments."""
        learner_key, actor_key = jax.random.split(key)
        actor = self._reset_actors()(actor_key)
        rate = self.config.learning_rate if learning_rate is None else learning_rate
        learner = self.learner.init(learner_key, actor.timestep.observation, rate)
        return TrainState(learner, actor)

    def initial_learner(self, key: jax.Array, learning_rate: Any = None) -> LearnerState:
        """A fresh learner for the split loop: the same parameters `initial_state` gives
        for the same key, initialised from a zero observation."""
        learner_key, _ = jax.random.split(key)
        spec = specs.observation_spec(self.config.observation_format(), padded=True)
        observation = {k: np.zeros((1,) + v.shape, v.dtype) for k, v in spec.items()}
        rate = self.config.learning_rate if learning_rate is None else learning_rate
        return self.learner.init(learner_key, observation, rate)

    def initial(self, key: jax.Array) -> Any:
        """What a run checkpoints: a `TrainState` in the compiled loop, the `LearnerState`
        in the split loop (the real game, or `actor_device`)."""
        if self.sim is None or self.config.actor_device is not None:
            return self.initial_learner(key)
        return self.initial_state(key)

    def _reset_actors(self):
        """key -> the actors' first state, compiled (run op by op, the resets take several
        times longer than compiling them). The network is initialised op by op: compiled,
        its initial weights would differ in the last bits."""
        def make():
            unroll, num_envs = self._unroll(), self.config.num_envs
            return jax.jit(lambda key: unroll.init(key, num_envs))

        return self._program("reset", make)

    def chunk(self, num_runs: int | None = None):
        """The compiled chunk (`make_train_chunk`), built once per agent and run count
        (one run's chunk and a sweep's run-by-run chunk share their compiled step)."""
        return self._program(("chunk", num_runs), lambda: make_train_chunk(
            self._unroll(), self.learner, self.config.updates_per_chunk,
            num_runs=num_runs, pipelined=self.config.pipelined))

    def _unroll(self):
        return self._program("unroll", lambda: make_unroll(self.sim, self.core,
                                                           self.config.unroll_length))

    def _program(self, key, make: Callable[[], Any]):
        """`programs[key]`, made by `make()` the first time it is asked for."""
        if key not in self.programs:
            self.programs[key] = make()
        return self.programs[key]


RUN_ONLY_FIELDS = ("seed", "learning_rate", "checkpoint_interval_s", "eval_episodes",
                   "best_eval_interval", "best_eval_episodes", "init_from")
"""The config fields that no built part or compiled program depends on (the learning
rate is part of the learner's state; the others are read by the run's loop)."""


@functools.cache
def build(config: TrainConfig) -> Agent:
    """Builds the simulator, network, actor and learner of a config: once per config,
    and shared by configs that differ only in `RUN_ONLY_FIELDS`, so that runs in one
    process (a run and its resumption, a sweep, its evaluations) share compiled code."""
    defaults = TrainConfig()
    parts = _build(dataclasses.replace(
        config, **{name: getattr(defaults, name) for name in RUN_ONLY_FIELDS}))
    return dataclasses.replace(parts, config=config)


@functools.cache
def _build(config: TrainConfig) -> Agent:
    sim = simulator(config.map_name, config.observation_format(), config.step_mul,
                    config.reward_index(), 1.0, float(config.discount), False,
                    computer=config.computer()) if config.backend == "simulator" else None
    network = make_network(config.agent, config.observation_format(),
                           dtype=config.compute_dtype)
    loss = make_actor_critic_loss(
        network, value_weight=config.value_weight, entropy_weight=config.entropy_weight,
        off_policy_correction=config.off_policy_correction, clip_epsilon=config.ppo_clip,
        reward_scale=config.reward_scale)
    ppo = config.off_policy_correction == "ppo"
    passes = dict(prepare=make_ppo_targets(network, config.gae_lambda, config.reward_scale),
                  epochs=config.ppo_epochs, minibatches=config.ppo_minibatches) if ppo else {}
    optimiser = OptimiserConfig(decay=config.rmsprop_decay, epsilon=config.rmsprop_epsilon,
                                max_grad_norm=config.max_grad_norm,
                                anneal_updates=config.total_updates,
                                warmup_updates=config.warmup_updates,
                                non_point_rate_scale=config.non_point_rate_scale)
    return Agent(config, sim, network, actor_core(network, functions=config.functions),
                 make_learner(network, loss, optimiser, **passes))


@dataclasses.dataclass(frozen=True)
class TrainResult:
    """What a finished run gives back.

    Attributes:
      state: the final state: a `TrainState` on the simulator, the `LearnerState` on
        the real game (`Agent.initial`).
      episode_steps, episode_scores: every training episode's end step and score.
      evaluation: the final evaluation's summary (None without one).
      seconds: wall-clock seconds of this call (compilation included).
      best_evaluation: the evaluation's summary for the best parameters (run_dir/best),
        with their `update`, `env_steps`, `score` and what it is (`chosen_by`); None
        without an evaluation, without best parameters yet, or where they are the final.
    """

    state: Any
    episode_steps: np.ndarray
    episode_scores: np.ndarray
    evaluation: dict | None
    seconds: float
    best_evaluation: dict | None = None


def _episode_rows(episodes, first_step: int, steps_per_update: int, k: int):
    """(end step, score) of every episode that ended in a chunk; leaves [U, K, B]."""
    ended = np.asarray(episodes.ended)
    u, t, _ = np.nonzero(ended)
    steps = first_step + u * steps_per_update + (t + 1) * (steps_per_update // k)
    return steps, np.asarray(episodes.score)[ended]


def run_config(run_dir: str) -> TrainConfig | None:
    """The config saved in a run (or sweep) directory's config.json; None if it has none."""
    path = os.path.join(run_dir, "config.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return TrainConfig.from_json(json.load(f))


def check_run_dir(run_dir: str, config: TrainConfig) -> None:
    """Raises ValueError if `run_dir` holds a run whose config differs from `config` in
    anything but `total_steps`."""
    saved = run_config(run_dir)
    if saved is not None and saved != config:
        diff = {k: (v, getattr(config, k)) for k, v in saved.to_json().items()
                if getattr(config, k) != v and k != "total_steps"}
        if diff:
            raise ValueError(f"{run_dir} holds a run with another config; differences "
                             f"(saved, given): {diff}. Use a new directory.")


def launch_games(config: TrainConfig, sc2path: str | None = None) -> GameEnvBatch:
    """`config.num_envs` StarCraft II games (launched on their first reset) for a run on
    the real game, each with its own seed."""
    return GameEnvBatch([
        make(config.map_name, config.screen_size, config.minimap_size, config.step_mul,
             seed=config.seed + i, screen_features=config.screen_features,
             minimap_features=config.minimap_features, discount=config.discount,
             backend="sc2", sc2path=sc2path, bot=config.opponent())
        for i in range(config.num_envs)])


ChunkRunner = Callable[[Any, int], tuple[Any, dict, np.ndarray, np.ndarray]]
"""(state, agent steps so far) -> (state, metrics {name: values}, the steps at which
episodes ended, their scores): one chunk of `updates_per_chunk` updates."""


def _compiled_chunks(agent: Agent) -> ChunkRunner:
    chunk, config = agent.chunk(), agent.config

    def run(state, first_step):
        state, metrics, episodes = chunk(state)
        metrics, episodes = data_parallel.gather((metrics, episodes))
        steps, scores = _episode_rows(episodes, first_step, config.steps_per_update,
                                      config.unroll_length)
        return state, metrics, steps, scores

    return run


def _split_chunks(loop: SplitLoop, actor: HostActor, config: TrainConfig) -> ChunkRunner:
    seen = len(actor.episode_returns)

    def run(state, first_step):
        nonlocal seen
        state, metrics = loop.run(state, config.updates_per_chunk)
        scores = np.array(actor.episode_returns[seen:], np.float64)
        seen += scores.size
        # Episodes are logged at the chunk's end (the actor runs ahead of the learner).
        steps = np.full(scores.size, first_step + config.updates_per_chunk
                        * config.steps_per_update)
        return state, jax.tree.map(lambda *m: np.stack(m), *metrics), steps, scores

    return run


def train(config: TrainConfig, run_dir: str, *, log: Callable[[str], None] = print,
          progress: bool = True, stop_after_updates: int | None = None,
          sc2path: str | None = None,
          games: Callable[[TrainConfig], dm_env.Environment] | None = None,
          devices: int = 1) -> TrainResult:
    """Trains (or resumes) a run in `run_dir`, then evaluates it.

    Args:
      config: the run. A resumed run may only change `total_steps`.
      run_dir: the run's directory (created if needed).
      log: where status lines go.
      progress: show a progress bar on stderr.
      stop_after_updates: stop (with a checkpoint, without evaluating) once this many
        updates are done, as a preempted job would; a later call resumes.
      sc2path: the game's install (backend "sc2"; default `$SC2PATH`).
      games: builds the batched environment of a run on the real game (default
        `launch_games`; e.g. games already running, or simulator servers).
      devices: how many of this process's devices to split the environments over
        (`data_parallel`; the simulator only). The run is the same program on any
        number, and its checkpoints resume on any number. In a run of several
        processes (`data_parallel.initialize` first, on every process) the
        environments are split over this many devices of every process; every process
        calls `train` alike, and process 0 alone logs and writes the run's files (the
        checkpoints are written by all, each its own part).

    Returns:
      The `TrainResult`.

    Raises:
      ValueError: if `run_dir` holds a run with a different config, `init_from`
        cannot start this one (`start_params`), or for devices the run cannot use.
    """
    start = time.time()
    over = _devices_mesh(config, devices)
    check_run_dir(run_dir, config)
    primary = data_parallel.is_primary()
    if not primary:
        log, progress = (lambda line: None), False
    agent = build(config)
    initial = None if has_checkpoint(run_dir) else start_params(agent)
    os.makedirs(run_dir, exist_ok=True)
    if primary:
        write_json_atomic(os.path.join(run_dir, "config.json"), config.to_json())
    state = placed_as_restored(agent.initial(jax.random.PRNGKey(config.seed)))
    checkpointer = Checkpointer(os.path.join(run_dir, "checkpoints"))
    update, env_steps = 0, 0
    resuming = checkpointer.latest_step() is not None
    if not resuming and initial is not None:
        state = with_params(state, initial)
        log(f"Starting from the parameters of {config.init_from}")
    if over is not None:
        state = data_parallel.place(state, over)
    if resuming:  # Into the state's placement: each process reads its own part.
        state, meta = checkpointer.restore(state)
        update, env_steps = meta["update"], meta["env_steps"]
        log(f"Resumed from update {update} ({env_steps} agent steps)")

    def params_now():
        """The parameters now, on this process's first device (as the evaluations take
        them)."""
        params = _params(state)
        return params if over is None else placed_as_restored(data_parallel.gather(params))
    # The best parameters so far, (metadata, params), and whether they await a save;
    # their directory is made at the first save.
    best_dir = os.path.join(run_dir, "best")
    best_checkpointer = best = None
    best_unsaved = False
    if os.path.isdir(best_dir):
        best_checkpointer = Checkpointer(best_dir, max_to_keep=1)
        if best_checkpointer.latest_step() is not None:
            params, meta = best_checkpointer.restore(_params(state))
            best = (meta, data_parallel.gather(params))
    resume = env_steps if update else None
    episodes_path = os.path.join(run_dir, "episodes.csv")
    if primary:
        metrics_log = CsvLog(os.path.join(run_dir, "metrics.csv"), resume_step=resume)
        episode_log = CsvLog(episodes_path, ("step", "score"), resume_step=resume)
        writer = SummaryWriter(os.path.join(run_dir, "tensorboard"))
    else:
        metrics_log = episode_log = writer = _Discard()
    bar = Progress(config.total_updates * config.steps_per_update,
                   show=("score", "score_max", "entropy")) if progress else None
    recent = []
    if resume:  # The rows up to the checkpoint (process 0 may not have dropped the rest).
        table = read_csv(episodes_path)
        recent = list(table["score"][table["step"] <= env_steps][-SCORE_WINDOW:])
    env = loop = None
    if agent.sim is None:
        env = (games or functools.partial(launch_games, sc2path=sc2path))(config)
    last_save = time.time()
    log(f"Training {config.agent} on {config.map_name} ({config.backend}): "
        f"{config.total_updates} updates of {config.num_envs} environments x "
        f"{config.unroll_length} steps (the first chunk compiles)")
    stop_at = config.total_updates if stop_after_updates is None else min(
        stop_after_updates, config.total_updates)
    try:
        if env is None and config.actor_device is None:
            run_chunk = _compiled_chunks(agent)
        elif update < stop_at:
            if env is None:  # Resumed runs start new episodes (the actor is not saved).
                actor = DeviceActor(agent._unroll(), config.num_envs,
                                    jax.random.fold_in(jax.random.PRNGKey(config.seed),
                                                       update),
                                    jax.local_devices()[config.actor_device],
                                    learner_device=jax.local_devices()[0])
            else:
                actor = HostActor(env, agent.core, config.unroll_length,
                                  seed=config.seed + update)
            loop = SplitLoop(actor, agent.learner, state.params)
            run_chunk = _split_chunks(loop, actor, config)
        while update < stop_at:
            chunk_start = time.time()
            state, metrics, steps, scores = run_chunk(state, env_steps)
            update += config.updates_per_chunk
            env_steps += config.updates_per_chunk * config.steps_per_update
            for step, score in zip(steps, scores):
                episode_log.write({"step": int(step), "score": float(score)})
            recent = (recent + scores.tolist())[-SCORE_WINDOW:]
            candidate = _best_candidate_score(agent, params_now, update, recent)
            if data_parallel.agree(candidate is not None and (
                    best is None or candidate > best[0]["score"])):
                best = ({"update": update, "env_steps": env_steps, "score": candidate,
                         "chosen_by": _chosen_by(config)},
                        data_parallel.gather(_params(state)))
                best_unsaved = True
            row = {"step": env_steps, "update": update, "wall_time": time.time() - start,
                   "steps_per_s": config.updates_per_chunk * config.steps_per_update
                   / (time.time() - chunk_start),
                   "episodes": int(scores.size),
                   "score": float(np.mean(recent)) if recent else float("nan"),
                   "score_max": float(np.max(recent)) if recent else float("nan"),
                   **{k: float(np.mean(v)) for k, v in metrics.items()}}
            if config.best_eval_interval:
                row["eval_score"] = candidate
            metrics_log.write(row)
            writer.scalars({k: v for k, v in row.items() if k != "step" and v is not None},
                           env_steps)
            if bar is not None:
                bar.update(env_steps, {"score": row["score"], "score_max": row["score_max"],
                                       "entropy": row["function_entropy"]})
            if (data_parallel.agree(time.time() - last_save >= config.checkpoint_interval_s)
                    or update >= stop_at):
                writer.flush()
                # The best first: a crash between the two saves then resumes from the
                # previous checkpoint, which chooses the same best again.
                if best_unsaved:
                    if best_checkpointer is None:
                        best_checkpointer = Checkpointer(best_dir, max_to_keep=1)
                    best_checkpointer.save(best[0]["update"], best[1], best[0])
                    best_unsaved = False
                checkpointer.save(update, state, {"update": update, "env_steps": env_steps})
                last_save = time.time()
        if loop is not None:
            loop.close()  # The evaluation steps the games next.
            loop = None
        episode_log.close()
        data_parallel.barrier("episodes written")
        episode_table = read_csv(episodes_path)
        if primary:
            _plot(run_dir, config)
        summary = best_summary = None

        def evaluate(params, name: str, extra: dict) -> dict:
            """Evaluates `params`; writes the summary, scores and `extra` to `name`."""
            if env is None:
                stats = evaluate_params(agent, params, config.eval_episodes,
                                        seed=config.seed + 1)
            else:
                stats = evaluation.run_host_episodes(
                    env, evaluation.host_core(agent.core, params),
                    agent.core.initial_carry(config.num_envs), config.eval_episodes,
                    seed=config.seed + 1)
            if primary:
                write_json_atomic(os.path.join(run_dir, name),
                                  {**stats.summary, "scores": stats.scores.tolist(), **extra,
                                   "config": config.to_json()})
            return stats.summary

        if config.eval_episodes and update >= config.total_updates:
            log(f"Evaluating for {config.eval_episodes} episodes")
            summary = evaluate(params_now(), "eval.json", {"agent_steps": env_steps})
            if best is not None and best[0]["update"] != update:
                log(f"Evaluating the best parameters (update {best[0]['update']}, "
                    f"{_chosen_by(config)} score {best[0]['score']:.2f}) for "
                    f"{config.eval_episodes} episodes")
                best_summary = {**evaluate(best[1], "eval_best.json", best[0]), **best[0]}
    finally:
        if loop is not None:
            loop.close()
        if env is not None:
            env.close()
        if bar is not None:
            bar.close()
        writer.close()
        metrics_log.close()
        episode_log.close()
        checkpointer.close()
        if best_checkpointer is not None:
            best_checkpointer.close()
    return TrainResult(state, episode_table["step"], episode_table["score"], summary,
                       time.time() - start, best_summary)


class _Discard:
    """A log that process 0 keeps, on the other processes of a run: every call does
    nothing."""

    def __getattr__(self, name: str) -> Callable[..., None]:
        return lambda *args, **kwargs: None


def _chosen_by(config: TrainConfig) -> str:
    """What a run's best score is: "evaluation" or "training window"."""
    return "evaluation" if config.best_eval_interval else "training window"


def best_eval_due(config: TrainConfig, update: int) -> bool:
    """Whether the chunk that ended at `update` passed a multiple of
    `best_eval_interval` (never without one)."""
    interval = config.best_eval_interval
    return bool(interval) and update // interval != (update - config.updates_per_chunk
                                                      ) // interval


def best_eval_score(agent: Agent, params: Any, seed: int) -> float:
    """The mean of a periodic evaluation of a run with seed `seed`: always the same
    episodes' randomness (seed + 2), so that the parameters face the same draws."""
    return evaluate_params(agent, params, agent.config.best_eval_episodes,
                           seed=seed + 2).summary["mean"]


def _best_candidate_score(agent: Agent, params: Callable[[], Any], update: int,
                          recent: list[float]) -> float | None:
    """The score by which the parameters after `update` (`params()`) compete to be the
    best, or None when they do not: with `best_eval_interval` a periodic evaluation's
    mean when one is due, without it the mean of the last `SCORE_WINDOW` training
    episodes `recent` once the window is full."""
    config = agent.config
    if not config.best_eval_interval:
        return float(np.mean(recent)) if len(recent) == SCORE_WINDOW else None
    if not best_eval_due(config, update):
        return None
    return best_eval_score(agent, params(), config.seed)


def _devices_mesh(config: TrainConfig, devices: int):
    """The mesh a run splits its environments over: `devices` devices of every process
    (None for one device in one process).

    Raises:
      ValueError: for a count below 1 or above this process's devices, a run on the
        real game, environments that do not split evenly, or an `actor_device` this
        process does not have or with more than one learner device.
    """
    check_positive_int("devices", devices)
    processes = jax.process_count()
    if config.actor_device is not None:
        if devices > 1 or processes > 1:
            raise ValueError(f"actor_device={config.actor_device} runs one learner on one "
                             f"device; it takes devices=1 in one process, not "
                             f"devices={devices} over {processes} processes")
        if config.actor_device >= jax.local_device_count():
            raise ValueError(f"actor_device={config.actor_device}, but this process has "
                             f"{jax.local_device_count()} devices: "
                             f"{jax.local_devices()}")
    if devices == 1 and processes == 1:
        return None
    first_devices(devices, config.num_envs, "devices")
    if config.backend != "simulator":
        raise ValueError(f"devices={devices} over {processes} processes needs the "
                         f"simulator backend, not {config.backend!r}")
    chosen = data_parallel.per_process(devices)
    if config.num_envs % len(chosen):
        raise ValueError(f"num_envs={config.num_envs} does not split evenly over the "
                         f"{len(chosen)} devices of {processes} processes; use a multiple "
                         f"of {len(chosen)}")
    return data_parallel.mesh(chosen)


def _params(state) -> Any:
    """The network parameters of what a run checkpoints (`Agent.initial`)."""
    return state.params if isinstance(state, LearnerState) else state.learner.params


def with_params(state, params) -> Any:
    """What a run checkpoints (`Agent.initial`), with other network parameters."""
    if isinstance(state, LearnerState):
        return state.replace(params=params)
    return state.replace(learner=state.learner.replace(params=params))


def has_checkpoint(run_dir: str) -> bool:
    """Whether `run_dir` holds a checkpoint to resume from."""
    directory = os.path.join(run_dir, "checkpoints")
    if not os.path.isdir(directory):
        return False
    with Checkpointer(directory) as checkpointer:
        return checkpointer.latest_step() is not None


def start_params(agent: Agent) -> Any:
    """The parameters a fresh run of `agent` starts from instead of new ones: those of
    its config's `init_from` run (an A3C run's last checkpoint, or a replay run's); None
    without one. Read before anything is compiled.

    Raises:
      ValueError: if init_from is not a run directory or has no checkpoint, or its
        network differs from `agent`'s in a shape or a parameter.
    """
    source = agent.config.init_from
    if source is None:
        return None
    try:
        if pretrained.is_replay_run(source):
            params = pretrained.load_replay_run(source).params
        else:
            params = load_run(source)[1]
    except FileNotFoundError as error:
        raise ValueError(f"init_from={source!r} cannot start this run: {error}") from None
    like = _params(jax.eval_shape(lambda: agent.initial(jax.random.PRNGKey(0))))
    pretrained.check_same_shapes(params, like, source)
    return jax.tree.map(lambda p, x: jnp.asarray(p, x.dtype), params, like)


def _plot(run_dir: str, config: TrainConfig) -> None:
    from sc2jax.experiments.reporting.paper import NETWORK_ROW, TABLE1

    table = read_csv(os.path.join(run_dir, "metrics.csv"))
    if table["step"].size == 0:
        return
    row = NETWORK_ROW.get(config.agent)
    paper = TABLE1.get(row, {}).get(config.map_name)  # The mini-games alone.
    references = {} if paper is None else {f"paper {row} best mean": paper[0]}
    plot_learning_curves({"run": (table["step"], table["score"])},
                         os.path.join(run_dir, "learning_curve.png"),
                         title=f"{config.agent} on {config.map_name}", references=references)


def evaluate_params(agent: Agent, params: Any, episodes: int, *, num_envs: int = 64,
                    seed: int = 0, temperature: float = 1.0) -> evaluation.EpisodeStats:
    """Runs `episodes` episodes of a trained network (sampling at `temperature`)."""
    core = agent.core if temperature == 1.0 else actor_core(
        agent.network, temperature, agent.config.functions)
    return evaluation.run_core_episodes(agent.sim, core, params, episodes, num_envs, seed)


def load_run(run_dir: str, step: int | None = None,
             best: bool = False) -> tuple[Agent, Any, dict]:
    """The agent, trained parameters and checkpoint metadata of a run directory: of
    checkpoint `step` (default: the last), or with `best` of the best parameters
    (run_dir/best; their metadata has `update`, `env_steps`, the `score` that chose them
    and what it is, `chosen_by`).

    Raises:
      FileNotFoundError: if `run_dir` has no config.json or no such checkpoint.
      ValueError: for both `step` and `best`.
    """
    if best and step is not None:
        raise ValueError(f"give a checkpoint step or best, not both (step={step!r})")
    config = run_config(run_dir)
    if config is None:
        raise FileNotFoundError(f"{run_dir} is not a run directory (no config.json)")
    agent = build(config)
    return (agent, *restore_params(agent, run_dir, step, best))


@dataclasses.dataclass(frozen=True)
class TrainedAgent:
    """A trained network ready to act on the simulator.

    Attributes:
      sim: the simulator it plays: an A3C run's own map and format, or for a replay run
        the map asked for at the dataset's resolutions and step_mul.
      core: its `ActorCore`.
      params: its parameters.
      name: what it is, e.g. "fullyconv" or "fullyconv (replays)".
      settings: what it plays with and how long it trained (for a results file): an A3C
        run's map, network, sizes, step_mul, functions and agent steps; a replay run's
        network, sizes, step_mul and updates.
      restored: a line saying what was restored from where.
    """

    sim: Simulator
    core: ActorCore
    params: Any
    name: str
    settings: dict
    restored: str


def trained_agent(run_dir: str, map_name: str | None = None, temperature: float = 1.0,
                  step: int | None = None, best: bool = False) -> TrainedAgent:
    """The network trained in `run_dir` (A3C with `train`, or on replays with
    `train_replays`), to play on the simulator: an A3C run on its own map (`map_name`
    is ignored), a replay run on `map_name`.

    Raises:
      FileNotFoundError: if `run_dir` is not a run or lacks the checkpoint.
      ValueError: for a replay run without `map_name`, or `best` for a replay run.
    """
    if pretrained.is_replay_run(run_dir):
        if not map_name or best:
            raise ValueError(f"{run_dir} is a replay run: it needs a map to play, and has "
                             f"no best parameters")
        run = pretrained.load_replay_run(run_dir, step)
        settings = dict(agent=run.agent, screen_size=run.fmt.screen_size[0],
                        minimap_size=run.fmt.minimap_size[0], step_mul=run.step_mul,
                        replay_updates=run.update)
        return TrainedAgent(run.simulator(map_name), actor_core(run.network, temperature),
                            run.params, f"{run.agent} (replays)", settings,
                            f"Restored {run.agent} after {run.update} updates on replays "
                            f"from {run_dir}")
    agent, params, meta = load_run(run_dir, step, best)
    config = agent.config
    # A simulator run keeps its computer opponent; a real-game run's opponent stays there.
    bot = config.bot if config.backend == "simulator" else None
    sim = build(dataclasses.replace(config, backend="simulator", bot=bot)).sim
    return TrainedAgent(sim, actor_core(agent.network, temperature, config.functions),
                        params, config.agent, *describe_run(config, meta, run_dir))


def describe_run(config: TrainConfig, meta: dict, run_dir: str) -> tuple[dict, str]:
    """(settings, restored) of an A3C run's restored parameters, as `TrainedAgent` has
    them: its own map and format, not a command's flags."""
    settings = dict(map=config.map_name, agent=config.agent, screen_size=config.screen_size,
                    minimap_size=config.minimap_size, step_mul=config.step_mul,
                    functions=config.functions, env_steps=meta["env_steps"])
    return settings, (f"Restored {config.agent} after {meta['env_steps']} agent steps from "
                      f"{run_dir}")


def restore_params(agent: Agent, run_dir: str, step: int | None = None,
                   best: bool = False) -> tuple[Any, dict]:
    """(parameters, metadata) of a run of `agent` (built from the run's config), as
    `load_run` returns them."""
    target = jax.eval_shape(lambda: agent.initial(jax.random.PRNGKey(0)))
    if best:
        missing = FileNotFoundError(f"{run_dir} has no best parameters (saved once "
                                    f"{SCORE_WINDOW} training episodes have ended, or "
                                    f"with best_eval_interval at the first evaluation)")
        if not os.path.isdir(os.path.join(run_dir, "best")):
            raise missing
        with Checkpointer(os.path.join(run_dir, "best"), max_to_keep=1) as checkpointer:
            if checkpointer.latest_step() is None:
                raise missing
            return checkpointer.restore(_params(target))
    with Checkpointer(os.path.join(run_dir, "checkpoints")) as checkpointer:
        state, meta = checkpointer.restore(target, step)
    return _params(state), meta
