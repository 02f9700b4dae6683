"""The settings of a supervised run on a replay dataset."""

from __future__ import annotations

import dataclasses

from sc2jax.checks import check_positive_int

AGENTS = ("atari", "fullyconv", "arfullyconv")
"""The feed-forward networks of the paper's section 5."""


@dataclasses.dataclass(frozen=True)
class ReplayTrainConfig:
    """How a dual-headed network is trained on a replay dataset.

    Attributes:
      dataset: the folder `convert_replays` wrote.
      agent: one of `AGENTS`.
      steps: Adam updates (0: evaluate the initial network, a random baseline).
      batch_size: records per update (64 in the paper).
      learning_rate: Adam's; None (the default): `default_learning_rate` for the
        dataset's screen size.
      value_weight: the value loss's weight against the policy loss.
      log_every: updates between rows of training metrics.
      eval_every: updates between evaluations on the fixed held-out batches.
      eval_batches: held-out minibatches per periodic evaluation.
      final_eval_batches: held-out minibatches of the final evaluation.
      checkpoint_every: updates between checkpoints.
      seed: the parameters' and the shuffles' seed.
    """

    dataset: str
    agent: str = "fullyconv"
    steps: int = 20_000
    batch_size: int = 64
    learning_rate: float | None = None
    value_weight: float = 1.0
    log_every: int = 100
    eval_every: int = 1_000
    eval_batches: int = 16
    final_eval_batches: int = 200
    checkpoint_every: int = 1_000
    seed: int = 0

    def __post_init__(self):
        if self.agent not in AGENTS:
            raise ValueError(f"unknown network {self.agent!r}; allowed: {list(AGENTS)}")
        if isinstance(self.steps, bool) or not isinstance(self.steps, int) or self.steps < 0:
            raise ValueError(f"steps must be an int >= 0, got {self.steps!r}")
        for name in ("batch_size", "log_every", "eval_every", "eval_batches",
                     "final_eval_batches", "checkpoint_every"):
            check_positive_int(name, getattr(self, name))
        for name in ("learning_rate", "value_weight"):
            if getattr(self, name) is not None and not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)!r}")


def default_learning_rate(agent: str, screen_size: int) -> float:
    """Adam's learning rate for a network at a screen size: 1e-3, but 1e-4 for FullyConv
    and arFullyConv above 32².

    Their 256-unit layer reads screen_size² × 32 inputs (131,072 at 64²). At 64² and 1e-3
    the first steps blew up the logits, and on a GPU both networks' value heads settled on
    a constant (loss ln 2 from update 300 on) and their function heads on the most
    frequent functions (docs/replays.md); at 1e-4 the value head kept learning. At 16² and
    32², 1e-3 cloned the demonstrations (docs/replays.md).
    """
    return 1e-3 if agent == "atari" or screen_size <= 32 else 1e-4
