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
import time

import jax
import jax.numpy as jnp
import numpy as np
from absl import app, flags

from sc2jax.environment import MAPS
from sc2jax.experiments.actor import actor_core
from sc2jax.experiments.checkpoints import write_json_atomic
from sc2jax.experiments.checks import check_positive_int
from sc2jax.experiments.config import TrainConfig, parse_names
from sc2jax.experiments.evaluation import core_episodes_fn
from sc2jax.experiments.learner import init_params
from sc2jax.experiments.paper import paper_rows
from sc2jax.experiments.trainer import build
from sc2jax.networks.factory import NETWORKS


def over_policies(fn):
    """`fn(params, key)` over a leading policy axis of both: `vmap` on an accelerator,
    `lax.map` (one policy after another, in the same program) on CPU."""
    if jax.default_backend() == "cpu":
        return lambda params, keys: jax.lax.map(lambda args: fn(*args), (params, keys))
    return jax.vmap(fn)


def random_search(config: TrainConfig, num_policies: int, *, temperature: float = 1e-3,
                  episodes: int = 20, policies_per_batch: int = 8,
                  log=print) -> dict:
    """Evaluates `num_policies` randomly initialised networks of `config.agent`.

    Args:
      config: the map, network and observation format (and `seed`).
      num_policies: policies to try.
      temperature: their softmax temperature (> 0; low is near-deterministic).
      episodes: episodes per policy (20 in the paper).
      policies_per_batch: policies evaluated together.

    Returns:
      {"policy_means": [...], "policy_max": [...], "best_policy", "best_mean", "max"}.

    Raises:
      ValueError: for non-positive counts or temperature, or a config not on the
        simulator.
    """
    for name, value in (("num_policies", num_policies), ("episodes", episodes),
                        ("policies_per_batch", policies_per_batch)):
        check_positive_int(name, value)
    if not temperature > 0:
        raise ValueError(f"temperature must be > 0, got {temperature!r}")
    if config.backend != "simulator":
        raise ValueError(f"random search evaluates its policies in one compiled program on "
                         f"the simulator; backend {config.backend!r} is not allowed")
    agent = build(config)
    core = actor_core(agent.network, temperature)
    obs = jax.eval_shape(lambda: jax.vmap(agent.sim.reset)(
        jax.random.split(jax.random.PRNGKey(0), 1))[1].observation)
    dummy = jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), obs)
    init = jax.vmap(lambda key: init_params(agent.network, key, dummy))
    evaluate = jax.jit(over_policies(core_episodes_fn(agent.sim, core, episodes)))
    key = jax.random.PRNGKey(config.seed)
    means, maxes = [], []
    start = time.time()
    while len(means) < num_policies:
        key, init_key, eval_key = jax.random.split(key, 3)
        params = init(jax.random.split(init_key, policies_per_batch))
        scores, _, done = jax.device_get(evaluate(
            params, jax.random.split(eval_key, policies_per_batch)))
        if not done.all():
            raise RuntimeError("an episode did not end within the map's time limit")
        means += scores.mean(axis=1).tolist()
        maxes += scores.max(axis=1).tolist()
        log(f"  {min(len(means), num_policies)} policies, best mean so far "
            f"{max(means[:num_policies]):.2f} [{time.time() - start:.0f} s]")
    means, maxes = means[:num_policies], maxes[:num_policies]
    best = int(np.argmax(means))
    return {"policy_means": means, "policy_max": maxes, "best_policy": best,
            "best_mean": means[best], "max": float(np.max(maxes)),
            "temperature": temperature, "episodes_per_policy": episodes,
            "seconds": time.time() - start, "config": config.to_json()}


_MAP = flags.DEFINE_string("map", "MoveToBeacon", f"Mini-game: one of {sorted(MAPS)}.")
_AGENT = flags.DEFINE_string("agent", "fullyconv", f"Network: one of {sorted(NETWORKS)}.")
_SCREEN = flags.DEFINE_integer("screen_size", 64, "Feature-screen resolution (16..256).")
_MINIMAP = flags.DEFINE_integer("minimap_size", 64, "Feature-minimap resolution (16..256).")
_SCREEN_FEATURES = flags.DEFINE_string("screen_features", "all", "Screen layers, or 'all'.")
_MINIMAP_FEATURES = flags.DEFINE_string("minimap_features", "all", "Minimap layers, or 'all'.")
_NUM_POLICIES = flags.DEFINE_integer("num_policies", 100, "Random policies to try.")
_TEMPERATURE = flags.DEFINE_float("temperature", 1e-3, "Their softmax temperature.")
_EPISODES = flags.DEFINE_integer("episodes", 20, "Episodes per policy.")
_BATCH = flags.DEFINE_integer("policies_per_batch", 8, "Policies evaluated together.")
_SEED = flags.DEFINE_integer("seed", 0, "Random seed.")
_OUTPUT = flags.DEFINE_string("output", None, "Write the results as JSON to this file.")


def main(argv) -> None:
    del argv
    try:
        config = TrainConfig(map_name=_MAP.value, agent=_AGENT.value,
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
