"""How large FullyConv LSTM's ConvLSTM output is in a run's checkpoints (docs/results.md).

    python scripts/lstm_output.py --run_dir=runs/lstm            # every checkpoint
    python scripts/lstm_output.py --run_dir=runs/lstm --steps=0,640

FullyConv LSTM's heads see only the ConvLSTM's output h = sigmoid(o) * tanh(c). Where h is near
zero at every pixel, the spatial policy (a 1x1 convolution of h) is uniform and its
gradient, which is proportional to h, vanishes: the run cannot learn to click. For each
checkpoint (step 0: the run's initial parameters), this prints, over the observations
after `select_army` in 32 fresh episodes of the run's map, the mean and max of |h| and
|c|, the spread of h over pixels, the spread of the screen logits over pixels, and the
mean of the output gate sigmoid(o) (= h / tanh(c)).
"""

import argparse
import os

import jax
import jax.numpy as jnp

from sc2jax.environment import FUNCTIONS
from sc2jax.environment.interface import dense
from sc2jax.experiments.training.trainer import build, restore_params, run_config

EPISODES = 32


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--run_dir", required=True)
    parser.add_argument("--steps", default=None,
                        help="comma-separated checkpoint steps (default: 0 and every one)")
    args = parser.parse_args()
    config = run_config(args.run_dir)
    if config is None:
        raise FileNotFoundError(f"{args.run_dir} is not a run directory (no config.json)")
    if config.agent != "fullyconv_lstm":
        raise ValueError(f"{args.run_dir} trains {config.agent!r}, not fullyconv_lstm")
    if args.steps is None:
        found = os.listdir(os.path.join(args.run_dir, "checkpoints"))
        steps = [0] + sorted(int(s) for s in found if s.isdigit())
    else:
        steps = [int(s) for s in args.steps.split(",")]
    agent = build(config)
    network, sim = agent.network, agent.sim
    # The same observations for every checkpoint: the step after `select_army`.
    states, _ = jax.vmap(sim.reset)(jax.random.split(jax.random.PRNGKey(100), EPISODES))
    select = dense.to_dense([FUNCTIONS.select_army("select")] * EPISODES)
    _, timestep = jax.vmap(sim.step)(states, select)
    obs = agent.core.observe(timestep.observation)
    for step in steps:
        if step > 0:
            params = restore_params(agent, args.run_dir, step)[0]
        else:  # The run's initial parameters, as `trainer.train` draws them.
            params = agent.initial_state(jax.random.PRNGKey(config.seed)).learner.params
        carry, out = network.apply(params, network.initial_carry(EPISODES), obs,
                                   jnp.ones(EPISODES, bool), method="step")
        logits = out.argument_logits[0].logits  # The screen argument (TYPES[0]).
        # h = sigmoid(o) * tanh(c), so the gate is h / tanh(c) where tanh(c) is not ~0.
        tanh_c = jnp.tanh(carry.c)
        defined = jnp.abs(tanh_c) > 1e-3
        gate = (jnp.where(defined, carry.h / jnp.where(defined, tanh_c, 1.0), 0.0).sum()
                / jnp.maximum(defined.sum(), 1))
        print(f"step {step:>7}: |h| mean {float(jnp.abs(carry.h).mean()):.5f} "
              f"max {float(jnp.abs(carry.h).max()):.5f}, h std over pixels "
              f"{float(carry.h.std(axis=(1, 2)).mean()):.5f}, |c| mean "
              f"{float(jnp.abs(carry.c).mean()):.4f}, screen logits std over pixels "
              f"{float(logits.std(axis=-1).mean()):.5f}, output gate mean "
              f"{float(gate):.4f}", flush=True)


if __name__ == "__main__":
    main()
