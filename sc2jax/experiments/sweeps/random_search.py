"""The paper's random-search baseline (section 4.3): many randomly initialised policy
networks at a low softmax temperature, each evaluated for 20 episodes, the best kept.

Policies are evaluated `policies_per_batch` at a time in one compiled call: vmapped
over their parameters on an accelerator, one after another (`lax.map`) on CPU, where
XLA runs the policy-grouped convolutions of the vmapped network about 5x slower per
policy. The command is `python -m sc2jax.experiments.random_search`.
"""

from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.checks import check_positive_int
from sc2jax.experiments.training.actor import actor_core
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.evaluation import core_episodes_fn
from sc2jax.experiments.training.learner import init_params
from sc2jax.experiments.training.trainer import build


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
