r"""The paper's random-search baseline: the best of many random FullyConv policies.

    python -m sc2jax.experiments.random_search --map=MoveToBeacon --num_policies=100

"Many independent, randomly initialised policy networks (with a low softmax
temperature that induces near-deterministic actions), evaluating each for 20 episodes
and keeping the one with the highest mean score" (paper §4.3). The default temperature,
1e-3, makes a fresh FullyConv near-deterministic: over 8 initialisations on MoveToBeacon's
first observation, its most likely available function has a mean probability of 1.00 at
16² and 0.98 at 64², and its most likely screen pixel 0.96 and 0.98 (at 0.1 the pixel's
is 0.07 and 0.008: a near-uniform click). Policies are evaluated `--policies_per_batch`
at a time in one compiled call: vmapped over their parameters on an accelerator, one
after another (`lax.map`) on CPU, where XLA runs the policy-grouped convolutions of the
vmapped network about 5x slower per policy (2.2 s against 11.3 s per policy of 20
MoveToBeacon episodes at 16², 2-core machine).
Prints the best policy's mean and the max episode score beside the paper's row, and
with --output writes every policy's scores as JSON.
"""

from __future__ import annotations

import sys

from absl import app, flags

from sc2jax.atomic import write_json_atomic
from sc2jax.experiments.reporting.paper import paper_rows
from sc2jax.experiments.sweeps.random_search import random_search
from sc2jax.experiments.training import flags as training_flags
from sc2jax.experiments.training.config import TrainConfig, parse_names

_MAP, _NETWORK, _SCREEN, _MINIMAP, _SCREEN_FEATURES, _MINIMAP_FEATURES, _SEED = (
    training_flags.define(("map", "network", "screen_size", "minimap_size", "screen_features",
                           "minimap_features", "seed")).values())
_NUM_POLICIES = flags.DEFINE_integer("num_policies", 100, "Random policies to try.")
_TEMPERATURE = flags.DEFINE_float("temperature", 1e-3, "Their softmax temperature.")
_EPISODES = flags.DEFINE_integer("episodes", 20, "Episodes per policy.")
_BATCH = flags.DEFINE_integer("policies_per_batch", 8, "Policies evaluated together.")
_OUTPUT = flags.DEFINE_string("output", None, "Write the results as JSON to this file.")

flags.adopt_module_key_flags(training_flags)


def main(argv) -> None:
    del argv
    training_flags.start_command()
    try:
        config = TrainConfig(map_name=_MAP.value, agent=_NETWORK.value,
                             screen_size=_SCREEN.value, minimap_size=_MINIMAP.value,
                             screen_features=parse_names(_SCREEN_FEATURES.value),
                             minimap_features=parse_names(_MINIMAP_FEATURES.value),
                             seed=_SEED.value)
        print(f"Random search: {_NUM_POLICIES.value} {config.agent} policies at temperature "
              f"{_TEMPERATURE.value}, {_EPISODES.value} episodes each (the first batch "
              f"compiles)", flush=True)
        result = random_search(config, _NUM_POLICIES.value, temperature=_TEMPERATURE.value,
                               episodes=_EPISODES.value, policies_per_batch=_BATCH.value)
    except ValueError as error:
        sys.exit(f"error: {error}")
    print(f"\n{config.map_name}, random search: best mean {result['best_mean']:.2f} "
          f"(policy {result['best_policy']}), max {result['max']:g}")
    print("The paper's Table 1:")
    print(paper_rows(config.map_name))
    if _OUTPUT.value:
        write_json_atomic(_OUTPUT.value, result)
        print(f"Wrote {_OUTPUT.value}")


if __name__ == "__main__":
    app.run(main)
