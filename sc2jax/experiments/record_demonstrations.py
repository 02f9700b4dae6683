r"""Records an agent's episodes on a mini-game as a replay dataset (demonstrations).

    python -m sc2jax.experiments.record_demonstrations --map=CollectMineralShards \
        --agent=scripted --episodes=200 --output=/tmp/demos/shards
    python -m sc2jax.experiments.train_replays --dataset=/tmp/demos/shards \
        --agent=fullyconv --run_dir=/tmp/runs/bc_shards

The agent is random, scripted, or (with `--run_dir`) a trained network: an A3C run on
its own map and format, or a replay run on `--map` at its dataset's format. Every agent
step becomes a record of the replay datasets' format with the exact observation, the
game's `available_actions` and the action sent, so `train_replays` clones the agent
(behaviour cloning) and `train --init_from` starts A3C from the clone
(`sc2jax.replay_sl.demonstrations`). Running the command again resumes.
"""

from __future__ import annotations

import sys
import time

import jax
from absl import app, flags

from sc2jax.environment import MAPS, make
from sc2jax.environment.agents import required_format
from sc2jax.experiments.training import evaluation, pretrained, trainer
from sc2jax.experiments.training import flags as training_flags
from sc2jax.experiments.training.actor import actor_core
from sc2jax.replay_sl.demonstrations import Recording, record_demonstrations

_MAP, _SCREEN, _MINIMAP, _STEP_MUL, _SEED = training_flags.define(
    ("map", "screen_size", "minimap_size", "step_mul", "seed")).values()
_AGENT = flags.DEFINE_string("agent", "scripted", f"Agent: one of {list(evaluation.AGENTS)} "
                             f"(ignored with --run_dir).")
_RUN_DIR = flags.DEFINE_string("run_dir", None, "Record the network trained in this run "
                               "directory: an A3C run (on its own map and format) or a "
                               "replay run (on --map, at its dataset's format).")
_STEP = flags.DEFINE_integer("checkpoint_step", None, "The run's checkpoint (default: last).")
_TEMPERATURE = flags.DEFINE_float("temperature", 1.0, "Softmax temperature of a trained "
                                  "network's actions.")
_EPISODES = flags.DEFINE_integer("episodes", 100, "Episodes to record (rounded up to whole "
                                 "batches of --num_envs).")
_NUM_ENVS = flags.DEFINE_integer("num_envs", 16, "Episodes played together.")
_OUTPUT = flags.DEFINE_string("output", None, "The dataset's folder.")

flags.adopt_module_key_flags(training_flags)


def _check_flags() -> None:
    if not _OUTPUT.value:
        raise ValueError("--output is required")
    if _MAP.value not in MAPS:
        raise ValueError(f"--map={_MAP.value!r} is unknown; allowed: {sorted(MAPS)}")
    if not _RUN_DIR.value and _AGENT.value not in evaluation.AGENTS:
        raise ValueError(f"--agent={_AGENT.value!r} is unknown; allowed: "
                         f"{list(evaluation.AGENTS)}")
    for flag in (_EPISODES, _NUM_ENVS, _STEP_MUL):
        if flag.value < 1:
            raise ValueError(f"--{flag.name} must be >= 1, got {flag.value}")
    if not _TEMPERATURE.value > 0:
        raise ValueError(f"--temperature must be > 0, got {_TEMPERATURE.value}")


def _network_agent(network, params, name: str):
    """(name, act, initial carry) of a trained network."""
    core = actor_core(network, _TEMPERATURE.value)

    def act(key, carry, obs, first):
        carry, action, _ = core.act(params, key, carry, obs, first)
        return carry, action

    return name, act, core.initial_carry(_NUM_ENVS.value)


def _agent_and_simulator():
    """(agent name, `demonstrations.Act`, initial carry, simulator) from the flags."""
    if _RUN_DIR.value and pretrained.is_replay_run(_RUN_DIR.value):
        run = pretrained.load_replay_run(_RUN_DIR.value, _STEP.value)
        return (*_network_agent(run.network, run.params, f"replays_{run.agent}"),
                run.simulator(_MAP.value, _SEED.value))
    if _RUN_DIR.value:
        agent, params, _ = trainer.load_run(_RUN_DIR.value, _STEP.value)
        if agent.sim is None:
            raise ValueError(f"{_RUN_DIR.value} trained on the real game; demonstrations "
                             f"are recorded on the simulator's mini-games")
        return (*_network_agent(agent.network, params, agent.config.agent), agent.sim)
    extra = required_format(_MAP.value) if _AGENT.value == "scripted" else {}
    sim = make(_MAP.value, _SCREEN.value, _MINIMAP.value, _STEP_MUL.value, **extra).simulator
    policy = evaluation.make_policy(_AGENT.value, _MAP.value, sim.fmt)

    def act(key, carry, obs, first):
        keys = jax.random.split(key, first.shape[0])
        return carry, jax.vmap(policy)(keys, obs)

    return _AGENT.value, act, None, sim


def main(argv) -> None:
    del argv
    training_flags.start_command()
    try:
        _check_flags()
        name, act, carry, sim = _agent_and_simulator()
    except (FileNotFoundError, ValueError) as error:
        sys.exit(f"error: {error}")
    recording = Recording(sim.game.name, name, _SEED.value, _NUM_ENVS.value)
    start = time.time()
    print(f"Recording {_EPISODES.value} episodes of the {name} agent on {recording.map_name} "
          f"into {_OUTPUT.value} ({_NUM_ENVS.value} at a time; the first batch compiles)",
          flush=True)
    try:
        summary = record_demonstrations(sim, act, carry, _OUTPUT.value, recording,
                                        _EPISODES.value)
    except ValueError as error:
        sys.exit(f"error: {error}")
    episodes = summary["replays"]
    records = sum(e["records"] for e in episodes)
    mean = sum(e["score"] for e in episodes) / len(episodes)
    print(f"\n{len(episodes)} episodes (mean score {mean:.2f}), {records} records, in "
          f"{time.time() - start:.0f} s; see {_OUTPUT.value}/conversion.json")


if __name__ == "__main__":
    app.run(main)
