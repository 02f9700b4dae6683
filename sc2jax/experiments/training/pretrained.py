"""Networks trained on replays, read back to act in the simulator or to start A3C.

A replay run (`replay_training.trainer.train_replays`) keeps its `ReplayTrainConfig` in
`config.json` and Orbax checkpoints of its `replay_sl.learner.LearnerState` in
`checkpoints/`; its network reads observations of the dataset's format
(`conversion.json`): every screen and minimap layer at the dataset's resolutions, the
`player` vector, and `available_actions`, which is what the simulator gives at the same
resolutions. So the same parameters can act on any mini-game (`evaluate --run_dir`) or
start an A3C run of the same network and format (`TrainConfig.init_from`).

    run = load_replay_run("/tmp/runs/fullyconv")
    core = actor_core(run.network)          # acts with run.params on run.fmt
"""

from __future__ import annotations

import dataclasses
import json
import os
from typing import Any

import jax
import numpy as np

from sc2jax.environment import make
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.experiments.training.checkpoints import Checkpointer
from sc2jax.networks.factory import make_network
from sc2jax.replay_sl.dataset import Settings, dataset_settings, schema
from sc2jax.replay_sl.learner import init, to_batch


def is_replay_run(run_dir: str) -> bool:
    """Whether `run_dir` holds a replay run (its config.json names a dataset)."""
    path = os.path.join(run_dir, "config.json")
    if not os.path.isfile(path):
        return False
    with open(path) as f:
        return "dataset" in json.load(f)


@dataclasses.dataclass(frozen=True)
class ReplayRun:
    """A replay run's network and parameters.

    Attributes:
      agent: the network's name ("atari", "fullyconv" or "arfullyconv").
      network: the Flax module.
      params: its trained parameters.
      fmt: the observation format it reads (the dataset's resolutions, every layer).
      step_mul: game loops per agent step of the dataset.
      update: the Adam updates behind the parameters.
    """

    agent: str
    network: Any
    params: Any
    fmt: ObservationFormat
    step_mul: int
    update: int

    def simulator(self, map_name: str, seed: int = 0) -> Simulator:
        """A mini-game's simulator in the observation format and step_mul the network
        was trained on."""
        return make(map_name, self.fmt.screen_size, self.fmt.minimap_size, self.step_mul,
                    seed=seed).simulator


def zero_batch(settings: Settings):
    """A `SupervisedBatch` of one all-zero record of a dataset's schema."""
    return to_batch({name: np.zeros((1, *shape), dtype)
                     for name, (dtype, shape) in schema(settings).items()})


def load_replay_run(run_dir: str, step: int | None = None) -> ReplayRun:
    """The network and parameters of a replay run: of checkpoint `step` (default: the
    last). The run's dataset must still be there (its settings give the format).

    Raises:
      FileNotFoundError: if `run_dir` is not a replay run, or has no checkpoint.
      ValueError: if the run's dataset is gone or of another format, or `step` was not
        saved.
    """
    if not is_replay_run(run_dir):
        raise FileNotFoundError(f"{run_dir} is not a replay run (no config.json naming a "
                                f"dataset)")
    with open(os.path.join(run_dir, "config.json")) as f:
        config = json.load(f)
    settings = dataset_settings(config["dataset"])
    fmt = ObservationFormat(screen_size=settings.screen_size,
                            minimap_size=settings.minimap_size)
    network = make_network(config["agent"], fmt)
    target = jax.eval_shape(lambda: init(network, zero_batch(settings), jax.random.PRNGKey(0),
                                         learning_rate=config["learning_rate"]))
    with Checkpointer(os.path.join(run_dir, "checkpoints")) as checkpointer:
        state, meta = checkpointer.restore(target, step)
    return ReplayRun(config["agent"], network, state.params, fmt, settings.step_mul,
                     int(meta["step"]))


def check_same_shapes(params: Any, like: Any, source: str) -> None:
    """Raises ValueError unless `params` has `like`'s tree and leaf shapes, naming the
    first difference (another network, resolution or layer set)."""
    got = {jax.tree_util.keystr(p): np.shape(x)
           for p, x in jax.tree_util.tree_leaves_with_path(params)}
    want = {jax.tree_util.keystr(p): np.shape(x)
            for p, x in jax.tree_util.tree_leaves_with_path(like)}
    for path in sorted(set(got) | set(want)):
        if got.get(path) != want.get(path):
            raise ValueError(
                f"the parameters of {source} do not fit this run's network: {path} is "
                f"{got.get(path, 'missing')} there and {want.get(path, 'missing')} here; "
                f"start from a run of the same agent, resolutions and layers")
