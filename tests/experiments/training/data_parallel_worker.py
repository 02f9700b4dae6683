"""One process of the data-parallel tests (test_data_parallel.py): trains a small
FullyConv on MoveToBeacon for a few updates over every device of every process, and
process 0 writes the parameters.

    python data_parallel_worker.py OUT.npz [COORDINATOR NUM_PROCESSES PROCESS_ID]
    python data_parallel_worker.py OUT.npz --train RUN_DIR

With --train it then trains a run in RUN_DIR with `trainer.train(devices=...)` over
this process's devices (checkpoints, evaluation), to be resumed on one device.
"""

import dataclasses
import sys

import jax
import numpy as np


def main(out: str, coordinator: str | None = None, num_processes: str | None = None,
         process_id: str | None = None) -> None:
    from sc2jax.experiments.training import data_parallel

    run_dir = num_processes if coordinator == "--train" else None
    if coordinator is not None and run_dir is None:
        data_parallel.initialize(coordinator, int(num_processes), int(process_id))
    from sc2jax.experiments.training.config import TrainConfig
    from sc2jax.experiments.training.trainer import build, train

    config = TrainConfig(
        map_name="MoveToBeacon", agent="fullyconv", screen_size=16, minimap_size=16,
        screen_features=("player_relative", "selected"), minimap_features=("player_relative",),
        functions=("no_op", "select_army", "Move_screen"), num_envs=4, unroll_length=8,
        learning_rate=5e-3, seed=3, updates_per_chunk=3)
    agent = build(config)
    over = data_parallel.mesh()
    state = data_parallel.place(agent.initial_state(jax.random.PRNGKey(config.seed)), over)
    assert state.actor.episode_return.sharding.num_devices == over.size
    state, metrics, _ = agent.chunk()(state)
    params = data_parallel.gather(state.learner.params)
    returns = data_parallel.gather(state.actor.episode_return)
    if jax.process_index() == 0:
        leaves = jax.tree.leaves(params)
        np.savez(out, returns=returns, loss=np.asarray(metrics["loss"]),
                 devices=over.size, processes=jax.process_count(),
                 **{f"param{i}": leaf for i, leaf in enumerate(leaves)})
    if run_dir is not None:
        result = train(dataclasses.replace(config, total_steps=192, eval_episodes=4),
                       run_dir, progress=False, devices=over.size)
        assert result.evaluation["episodes"] == 4


if __name__ == "__main__":
    main(*sys.argv[1:])
