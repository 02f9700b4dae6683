r"""Evaluates an agent on a mini-game of the embedded simulator.

    python -m sc2jax.experiments.evaluate --map=MoveToBeacon --agent=scripted \
        --episodes=100 --output=/tmp/eval.json

Prints the mean, std and max episode score beside the paper's Table 1, and with
`--output` writes them as JSON: `episodes`, `mean`, `std`, `max`, `min`, `scores` (every
episode's score) and the resolved `config`.
"""

from __future__ import annotations

import json
import os
import sys
import time

from absl import app, flags

from sc2jax.environment import MAPS, make
from sc2jax.environment.agents import required_format
from sc2jax.experiments import evaluation
from sc2jax.experiments.paper import paper_rows

_MAP = flags.DEFINE_string("map", "MoveToBeacon", f"Mini-game: one of {sorted(MAPS)}.")
_AGENT = flags.DEFINE_string("agent", "random", f"Agent: one of {list(evaluation.AGENTS)}.")
_EPISODES = flags.DEFINE_integer("episodes", 100, "Episodes to run.")
_NUM_ENVS = flags.DEFINE_integer("num_envs", 64, "Environments run together per batch.")
_SCREEN = flags.DEFINE_integer("screen_size", 64, "Feature-screen resolution (16..256).")
_MINIMAP = flags.DEFINE_integer("minimap_size", 64, "Feature-minimap resolution (16..256).")
_STEP_MUL = flags.DEFINE_integer("step_mul", 8, "Game loops per agent step.")
_SEED = flags.DEFINE_integer("seed", 0, "Random seed.")
_OUTPUT = flags.DEFINE_string("output", None, "Write the results as JSON to this file.")


def check_flags() -> None:
    """Raises ValueError for bad flag values, before anything is compiled."""
    if _MAP.value not in MAPS:
        raise ValueError(f"--map={_MAP.value!r} is unknown; allowed: {sorted(MAPS)}")
    if _AGENT.value not in evaluation.AGENTS:
        raise ValueError(f"--agent={_AGENT.value!r} is unknown; allowed: "
                         f"{list(evaluation.AGENTS)}")
    for flag in (_EPISODES, _NUM_ENVS, _STEP_MUL):
        if flag.value < 1:
            raise ValueError(f"--{flag.name} must be >= 1, got {flag.value}")


def write_json(path: str, payload: dict) -> None:
    """Writes JSON atomically (a temporary file renamed over the target)."""
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        json.dump(payload, f, indent=1)
    os.replace(tmp, path)


def main(argv) -> None:
    del argv
    try:
        check_flags()
    except ValueError as error:
        sys.exit(f"error: {error}")
    extra = required_format(_MAP.value) if _AGENT.value == "scripted" else {}
    env = make(_MAP.value, screen_size=_SCREEN.value, minimap_size=_MINIMAP.value,
               step_mul=_STEP_MUL.value, **extra)
    sim = env.simulator
    policy = evaluation.make_policy(_AGENT.value, sim)
    start = time.time()

    def progress(stats: evaluation.EpisodeStats) -> None:
        s = stats.summary
        print(f"  {s['episodes']:>5} episodes  mean {s['mean']:8.2f}  max {s['max']:7.1f}  "
              f"({time.time() - start:.0f} s)", flush=True)

    print(f"Evaluating the {_AGENT.value} agent on {_MAP.value} for {_EPISODES.value} "
          f"episodes ({min(_NUM_ENVS.value, _EPISODES.value)} environments at a time; "
          f"the first batch compiles)", flush=True)
    stats = evaluation.run_episodes(sim, policy, _EPISODES.value, _NUM_ENVS.value,
                                    _SEED.value, progress)
    s = stats.summary
    print(f"\n{_MAP.value}, {_AGENT.value} agent: mean {s['mean']:.2f} ± {s['std']:.2f} (std), "
          f"max {s['max']:g}, over {s['episodes']} episodes "
          f"[{time.time() - start:.0f} s]")
    print("The paper's Table 1:")
    print(paper_rows(_MAP.value))
    if _OUTPUT.value:
        config = {flag.name: flag.value for flag in (_MAP, _AGENT, _EPISODES, _NUM_ENVS,
                                                     _SCREEN, _MINIMAP, _STEP_MUL, _SEED)}
        write_json(_OUTPUT.value, {**s, "scores": stats.scores.tolist(),
                                   "steps": stats.steps.tolist(), "config": config})
        print(f"Wrote {_OUTPUT.value}")


if __name__ == "__main__":
    app.run(main)
