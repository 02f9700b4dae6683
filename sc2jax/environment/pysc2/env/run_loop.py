"""PySC2's `pysc2.env.run_loop`: agents play an environment, episode after episode."""

from __future__ import annotations

import time
from collections.abc import Sequence


def run_loop(agents: Sequence, env, max_frames: int = 0, max_episodes: int = 0) -> None:
    """Plays `agents` (one per player) on `env` until `max_episodes` episodes or
    `max_frames` agent steps have been played (0: no limit), as PySC2's `run_loop`.

    Each agent is set up once with its observation and action spec, reset at the start
    of each episode, and asked for an action at every timestep, the last one included;
    the last one's action is not sent. Prints the time taken and the steps per second.
    """
    if max_frames < 0 or max_episodes < 0:
        raise ValueError(f"max_frames and max_episodes must be >= 0 (0: no limit), got "
                         f"{max_frames!r}, {max_episodes!r}")
    frames = episodes = 0
    start = time.time()
    for agent, observation_spec, action_spec in zip(agents, env.observation_spec(),
                                                    env.action_spec()):
        agent.setup(observation_spec, action_spec)
    try:
        while not max_episodes or episodes < max_episodes:
            episodes += 1
            timesteps = env.reset()
            for agent in agents:
                agent.reset()
            while True:
                frames += 1
                actions = [agent.step(timestep) for agent, timestep in zip(agents, timesteps)]
                if max_frames and frames >= max_frames:
                    return
                if timesteps[0].last():
                    break
                timesteps = env.step(actions)
    except KeyboardInterrupt:
        pass
    finally:
        elapsed = time.time() - start
        print(f"Took {elapsed:.3f} seconds for {frames} steps: {frames / elapsed:.3f} fps")
