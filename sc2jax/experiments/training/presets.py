"""Named training configurations: the README's quick start and the paper's settings per map.

    python -m sc2jax.experiments.train --preset=beacon_quickstart
    python -m sc2jax.experiments.train --preset=paper_defeat_roaches --total_steps=5000000

A preset is a frozen `TrainConfig`; a flag given on the command line overrides its field.
"""

from __future__ import annotations

import dataclasses
import re

from sc2jax.environment.interface.map_names import MINI_GAMES
from sc2jax.experiments.training.config import TrainConfig


@dataclasses.dataclass(frozen=True)
class Preset:
    """A named configuration.

    Attributes:
      name: the `--preset` value.
      description: what it is for, and where its settings come from.
      config: the run's settings.
    """

    name: str
    description: str
    config: TrainConfig


def _snake(name: str) -> str:
    return re.sub(r"(?<!^)(?=[A-Z])", "_", name).lower()


_QUICKSTART = Preset(
    name="beacon_quickstart",
    description=(
        "The README's main job: FullyConv on MoveToBeacon at a scale a 2-core CPU trains in "
        "minutes (16x16 layers, 3 of the 38 feature layers, the 3 functions the task needs, "
        "4 environments, 16-step unrolls, 96k agent steps). Mean 25.9 over 100 episodes on "
        "our 2-core EPYC (docs/results.md); the paper's best FullyConv mean is 26."),
    config=TrainConfig(
        map_name="MoveToBeacon", agent="fullyconv", screen_size=16, minimap_size=16,
        screen_features=("player_relative", "selected"), minimap_features=("player_relative",),
        functions=("no_op", "select_army", "Move_screen"), num_envs=4, unroll_length=16,
        learning_rate=5e-3, seed=11, total_steps=96_000))

_PAPER = tuple(
    Preset(name=f"paper_{_snake(map_name)}",
           description=(f"{map_name} with the paper's settings (section 4.3): FullyConv, 64x64 "
                        "feature layers with all layers and all 573 functions, step_mul 8, "
                        "K = 40, entropy 1e-3, RMSProp annealed linearly to half. The paper "
                        "sampled the rate in [1e-5, 1e-3] (use `sweep` for that) and trained "
                        "up to 600M steps; set --total_steps to what the machine allows."),
           config=TrainConfig(map_name=map_name))
    for map_name in MINI_GAMES)

_TABLE1_GPU = Preset(
    name="table1_gpu",
    description=(
        "scripts/table1_gpu.py's settings for one GPU: FullyConv with the paper's inputs and "
        "actions (64x64, every layer, all 573 functions), 128 environments x K = 40, 10M "
        "agent steps per map, and the split learning rates that trained MoveToBeacon and "
        "CollectMineralShards best on the CPU (spatial heads 2e-2, the rest 1e-3; "
        "docs/results.md), the best parameters chosen by evaluation. A first guess: not yet "
        "run on a GPU."),
    config=TrainConfig(num_envs=128, unroll_length=40, total_steps=10_000_000,
                       learning_rate=2e-2, non_point_rate_scale=0.05, best_eval_interval=200,
                       updates_per_chunk=20))

PRESETS: dict[str, Preset] = {p.name: p for p in (_QUICKSTART, *_PAPER, _TABLE1_GPU)}


def get_preset(name: str) -> Preset:
    """The preset called `name`.

    Raises:
      ValueError: for an unknown name, listing the known ones.
    """
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; allowed: {sorted(PRESETS)}")
    return PRESETS[name]
