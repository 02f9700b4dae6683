"""The paper's section 5 measures on held-out replay records: Table 2's top-1 and top-5
accuracies, the value accuracy overall and by game time, the next build command's
accuracy, and the most-frequent-function baseline.

    predict = make_predict(network)
    examples = gather(predict, params, test_batches)     # per-example results
    summary = summarize(examples, function_counts(train_batches))
"""

from __future__ import annotations

import collections
from collections.abc import Iterable

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment.interface.functions import FUNCTIONS, NUM_FUNCTIONS
from sc2jax.losses.supervised import SupervisedBatch, supervised_ranks
from sc2jax.networks.policy import mask_function_logits
from sc2jax.replay_sl.learner import to_batch

LOOPS_PER_MINUTE = 22.4 * 60
"""Game loops per minute of game time at Faster speed."""
BUILD_PREFIXES = ("Build_", "Train_", "TrainWarp_", "Research_", "Morph_")
"""The functions that build, train, research or morph: the next build command."""
BUILD = np.asarray([f.name.startswith(BUILD_PREFIXES) for f in FUNCTIONS])


def make_predict(network):
    """`predict(params, batch) -> per-example ranks and value logits`, jitted
    (`losses.supervised.supervised_ranks`; arFullyConv's arguments teacher-forced)."""

    @jax.jit
    def predict(params, batch: SupervisedBatch) -> dict:
        out = network.apply(params, batch.observation, batch.action)
        available = batch.observation["available_actions_mask"]
        ranks = supervised_ranks(out, batch.action, available)
        # The rank among the available build commands alone (MSC's "next build" task).
        builds = mask_function_logits(out.function_logits, available & BUILD[None, :])
        target = jnp.take_along_axis(builds, batch.action.function[:, None], axis=-1)
        return {**ranks, "build_rank": jnp.sum(builds > target, axis=-1),
                "value_logit": out.value}

    return predict


def gather(predict, params, batches: Iterable[dict]) -> dict[str, np.ndarray]:
    """Runs `predict` over record batches (`dataset.loader`'s); returns the per-example
    results with the records' labels: arrays [N]."""
    parts = collections.defaultdict(list)
    for records in batches:
        batch = to_batch(records)
        out = jax.device_get(predict(params, batch))
        label = np.asarray(records["action_function"], np.int64)
        parts["label"].append(label)
        parts["label_available"].append(
            np.asarray(records["available_actions_mask"])[np.arange(len(label)), label])
        parts["available"].append(np.asarray(batch.observation["available_actions_mask"]))
        parts["game_loop"].append(np.asarray(records["game_loop"]))
        parts["outcome"].append(np.asarray(records["value"]))
        for name, value in out.items():
            parts[name].append(np.asarray(value))
    return {name: np.concatenate(value) for name, value in parts.items()}


def function_counts(batches: Iterable[dict]) -> np.ndarray:
    """int64 [NUM_FUNCTIONS]: how often each function is a label in `batches`."""
    counts = np.zeros(NUM_FUNCTIONS, np.int64)
    for records in batches:
        counts += np.bincount(np.asarray(records["action_function"], np.int64),
                              minlength=NUM_FUNCTIONS)
    return counts


def _share(hit: np.ndarray, where: np.ndarray | None = None) -> float | None:
    hit = hit if where is None else hit[where]
    return float(np.mean(hit)) if hit.size else None


def summarize(examples: dict[str, np.ndarray], train_counts: np.ndarray | None = None,
              *, max_minute: int = 30) -> dict:
    """The section's measures from `gather`'s examples.

    Returns a dict of:
      examples: how many;
      action_top1/top5, screen_top1/top5, minimap_top1/top5: Table 2's accuracies (the
        arguments' over the examples whose label takes them);
      value_accuracy, value_after_15_min, value_by_minute ([minute, examples, accuracy]
        rows by whole minutes of game time, up to `max_minute`);
      build_top1, build_top5, build_examples: the function's accuracy where the label
        builds, trains, researches or morphs (`BUILD_PREFIXES`); next_build_top1/top5:
        there, its rank among the available build commands alone (the next build
        command, as MSC measures it);
      label_available: the share of labels that the records' own mask allows (the rest
        were added by `learner.to_batch`); mean_available: the mask's mean size;
      majority_top1/top5 (with `train_counts`): predicting the functions most frequent in
        `train_counts` among each example's available ones.
    """
    rank = examples["function"]
    correct = (examples["value_logit"] > 0) == (examples["outcome"] > 0.5)
    minute = (examples["game_loop"] // LOOPS_PER_MINUTE).astype(int)
    build = BUILD[examples["label"]]
    out = {"examples": int(rank.size),
           "action_top1": _share(rank < 1), "action_top5": _share(rank < 5)}
    for name in ("screen", "minimap"):
        uses = examples[f"uses_{name}"]
        out[f"{name}_top1"] = _share(examples[name] < 1, uses)
        out[f"{name}_top5"] = _share(examples[name] < 5, uses)
    out.update(
        value_accuracy=_share(correct),
        value_after_15_min=_share(correct, minute >= 15),
        value_by_minute=[[m, int(np.sum(minute == m)), _share(correct, minute == m)]
                         for m in range(max_minute + 1) if np.any(minute == m)],
        build_top1=_share(rank < 1, build), build_top5=_share(rank < 5, build),
        next_build_top1=_share(examples["build_rank"] < 1, build),
        next_build_top5=_share(examples["build_rank"] < 5, build),
        build_examples=int(build.sum()),
        label_available=_share(examples["label_available"]),
        mean_available=float(np.mean(examples["available"].sum(axis=1))))
    if train_counts is not None:
        # Each example's functions ranked by their training frequency, among its own
        # available ones: the label's rank is the number of available functions more
        # frequent than it (ties broken by id).
        order = np.lexsort((np.arange(NUM_FUNCTIONS), -train_counts))
        position = np.empty(NUM_FUNCTIONS, np.int64)
        position[order] = np.arange(NUM_FUNCTIONS)
        label_position = position[examples["label"]]
        ahead = examples["available"] & (position[None, :] < label_position[:, None])
        majority_rank = ahead.sum(axis=1)
        out["majority_top1"] = _share(majority_rank < 1)
        out["majority_top5"] = _share(majority_rank < 5)
        out["majority_function"] = FUNCTIONS[int(order[0])].name
    return out
