"""The supervised training loop on a replay dataset, with checkpoints, resume, logs,
TensorBoard, a progress bar, plots and evaluation on the fixed held-out games.

A run directory gets:

- `config.json`: the `ReplayTrainConfig`; a run resumes only with the same one (but
  `steps`, which may grow);
- `checkpoints/`: Orbax checkpoints of the parameters and Adam's state;
- `train.csv` and `test.csv`: the training minibatches' metrics (means over
  `log_every` updates) and the periodic held-out evaluations;
- `tensorboard/`: both, as scalars;
- `eval.json`: the final held-out evaluation (`evaluation.summarize`), with the
  most-frequent-function baseline and the loop's speed (records per second of this
  session's updates after its first, which compiles; periodic evaluations and
  checkpoints included);
- `curves.png`: the held-out accuracies over training, and the value's accuracy by
  game time.
"""

from __future__ import annotations

import dataclasses
import json
import os
import time

import jax

from sc2jax.atomic import atomic_write, write_json_atomic
from sc2jax.checks import check_not_a_file
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.experiments.replay_training.config import (
    ReplayTrainConfig,
    default_learning_rate,
)
from sc2jax.experiments.replay_training.evaluation import (
    function_counts,
    gather,
    make_predict,
    summarize,
)
from sc2jax.experiments.reporting.metrics_log import CsvLog, read_csv
from sc2jax.experiments.reporting.progress import Progress
from sc2jax.experiments.reporting.tensorboard import SummaryWriter
from sc2jax.experiments.training.checkpoints import Checkpointer
from sc2jax.networks import make_network
from sc2jax.replay_sl.dataset import dataset_settings, loader
from sc2jax.replay_sl.learner import init, make_update, to_batch

EVAL_SEED = 12345
"""The held-out batches' shuffle: the same records for every run on a dataset."""
TRAIN_METRICS = ("loss", "value_loss", "function_loss", "argument_loss", "action_top1",
                 "action_top5", "screen_top1", "minimap_top1", "value_accuracy")
MIN_EXAMPLES_PER_MINUTE = 50
"""Minutes of game time with fewer held-out records are left out of the value plot."""
READ_THREADS = min(8, os.cpu_count() or 1)
"""Threads reading training minibatches ahead of the updates."""
TEST_METRICS = ("action_top1", "action_top5", "screen_top1", "screen_top5", "minimap_top1",
                "minimap_top5", "value_accuracy", "build_top1")


def _check_run_dir(run_dir: str, config: ReplayTrainConfig) -> None:
    check_not_a_file("run_dir", run_dir)
    path = os.path.join(run_dir, "config.json")
    if not os.path.exists(path):
        return
    with open(path) as f:
        saved = json.load(f)
    given = dataclasses.asdict(config)
    diff = {k: (v, given.get(k)) for k, v in saved.items() if given.get(k) != v and k != "steps"}
    if diff:
        raise ValueError(f"{run_dir} holds a run with another config; differences (saved, "
                         f"given): {diff}. Use a new directory.")


class _Batches:
    """The training minibatches in order: epoch e is the training split shuffled with
    seed + e. Grain reads, converts and copies to the device the next `READ_THREADS`
    batches on threads while the current one trains (one thread leaves a GPU idle: a
    batch of 64 takes about 20 ms to read and convert on one core)."""

    def __init__(self, config: ReplayTrainConfig):
        self.config, self.epoch, self.data = config, None, None
        self.per_epoch = len(self.epoch_data(0))
        if self.per_epoch == 0:
            raise ValueError(f"the training split of {config.dataset!r} has fewer records "
                             f"than one batch of {config.batch_size}")

    def epoch_data(self, epoch: int):
        """The training split shuffled for `epoch`, as minibatches."""
        if epoch != self.epoch:
            self.epoch = epoch
            self.data = loader(self.config.dataset, "train", batch_size=self.config.batch_size,
                               seed=self.config.seed + epoch, drop_remainder=True)
        return self.data

    def iterate(self, start: int, stop: int):
        """Yields the batches (`to_batch`, on the default device) of updates start..stop-1."""
        import grain

        options = grain.ReadOptions(num_threads=READ_THREADS,
                                    prefetch_buffer_size=2 * READ_THREADS)
        step = start
        while step < stop:
            epoch, offset = divmod(step, self.per_epoch)
            count = min(self.per_epoch - offset, stop - step)
            data = self.epoch_data(epoch)[offset:offset + count].map(
                lambda records: jax.device_put(to_batch(records)))
            yield from data.to_iter_dataset(options)
            step += count


def _plot(run_dir: str, summary: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    test = read_csv(os.path.join(run_dir, "test.csv"))
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    if test and test["step"].size:
        for name in ("value_accuracy", "action_top1", "action_top5", "screen_top1"):
            left.plot(test["step"], test[name], marker=".", label=name)
        left.legend()
    else:
        left.text(0.5, 0.5, "not trained", ha="center", transform=left.transAxes)
    left.set(xlabel="updates", ylabel="held-out accuracy", ylim=(0, 1),
             title="Held-out accuracy over training")
    rows = [r for r in summary["value_by_minute"] if r[1] >= MIN_EXAMPLES_PER_MINUTE]
    right.bar([r[0] for r in rows], [r[2] for r in rows])
    right.axhline(0.5, color="grey", linestyle="--", label="chance")
    right.set(xlabel="game time (minutes)", ylabel="value accuracy", ylim=(0, 1),
              title=f"Value accuracy by game time (minutes with "
                    f"{MIN_EXAMPLES_PER_MINUTE}+ records)")
    right.legend()
    fig.tight_layout()
    with atomic_write(os.path.join(run_dir, "curves.png"), "wb") as f:
        fig.savefig(f, format="png")
    plt.close(fig)


def train_replays(config: ReplayTrainConfig, run_dir: str, *, log=print,
                  progress: bool = True) -> dict:
    """Trains (or resumes) a run, then evaluates it on the held-out split.

    Returns:
      The final evaluation (what `eval.json` holds).

    Raises:
      ValueError: for a folder that is not a dataset, a dataset without both splits, or
        a run directory that holds a run with another config.
    """
    settings = dataset_settings(config.dataset)
    if config.learning_rate is None:
        config = dataclasses.replace(config, learning_rate=default_learning_rate(
            config.agent, settings.screen_size))
    test = loader(config.dataset, "test", batch_size=config.batch_size, seed=EVAL_SEED,
                  drop_remainder=True)
    batches = _Batches(config)
    if len(test) == 0:
        raise ValueError(f"the test split of {config.dataset!r} has fewer records than one "
                         f"batch of {config.batch_size}")
    _check_run_dir(run_dir, config)
    os.makedirs(run_dir, exist_ok=True)
    write_json_atomic(os.path.join(run_dir, "config.json"), dataclasses.asdict(config))
    network = make_network(config.agent, ObservationFormat(
        screen_size=settings.screen_size, minimap_size=settings.minimap_size))
    state = init(network, to_batch(test[0]), jax.random.PRNGKey(config.seed),
                 learning_rate=config.learning_rate)
    update = make_update(network, learning_rate=config.learning_rate,
                         value_weight=config.value_weight)
    predict = make_predict(network)
    checkpointer = Checkpointer(os.path.join(run_dir, "checkpoints"))
    step = 0
    if checkpointer.latest_step() is not None:
        state, meta = checkpointer.restore(state)
        step = meta["step"]
        log(f"Resumed from update {step}")
    resume = step if step else None
    train_log = CsvLog(os.path.join(run_dir, "train.csv"), ("step", *TRAIN_METRICS),
                       resume_step=resume)
    test_log = CsvLog(os.path.join(run_dir, "test.csv"), ("step", *TEST_METRICS),
                      resume_step=resume)
    writer = SummaryWriter(os.path.join(run_dir, "tensorboard"))
    held_out = [test[i] for i in range(min(config.eval_batches, len(test)))]

    def evaluate_now(at: int) -> None:
        found = summarize(gather(predict, state.params, held_out))
        row = {name: found[name] for name in TEST_METRICS}
        test_log.write({"step": at, **row})
        writer.scalars({f"test/{k}": v for k, v in row.items() if v is not None}, at)
        writer.flush()

    log(f"Training {config.agent} on {config.dataset}: {batches.per_epoch} batches of "
        f"{config.batch_size} per epoch, {len(test)} held-out batches; updates {step} to "
        f"{config.steps}")
    bar = Progress(max(config.steps, 1), show=("loss", "action_top1", "value_accuracy")
                   ) if progress else None
    pending, started, timed = [], None, 0  # metrics stay on the device until logged
    if step == 0 and config.steps > 0:
        evaluate_now(0)
    for batch in batches.iterate(step, config.steps):
        state, metrics = update(state, batch)
        step, timed = step + 1, timed + (started is not None)
        if started is None:  # The speed is timed from the end of the first (compiled) update.
            jax.block_until_ready(state)
            started = time.time()
        pending.append({name: metrics[name] for name in TRAIN_METRICS})
        if step % config.log_every == 0 or step == config.steps:
            pending = jax.device_get(pending)
            row = {name: sum(float(m[name]) for m in pending) / len(pending)
                   for name in TRAIN_METRICS}
            train_log.write({"step": step, **row})
            writer.scalars({f"train/{k}": v for k, v in row.items()}, step)
            pending = []
            if bar:
                bar.update(step, row)
        if step % config.eval_every == 0 or step == config.steps:
            evaluate_now(step)
        if step % config.checkpoint_every == 0 or step == config.steps:
            checkpointer.save(step, state, {"step": step})
    jax.block_until_ready(state)
    seconds = time.time() - started if timed else None
    if bar:
        bar.close()
    log("Final evaluation on the held-out games")
    final = summarize(
        gather(predict, state.params,
               (test[i] for i in range(min(config.final_eval_batches, len(test))))),
        function_counts(batches.epoch_data(0)[i] for i in range(
            min(config.final_eval_batches, batches.per_epoch))))
    final.update(agent=config.agent, updates=step, dataset_settings=dataclasses.asdict(settings),
                 train_samples_per_second=(timed * config.batch_size / seconds
                                           if timed else None))
    write_json_atomic(os.path.join(run_dir, "eval.json"), final)
    for closing in (train_log, test_log, writer, checkpointer):
        closing.close()
    _plot(run_dir, final)
    return final
