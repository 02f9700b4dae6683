"""PySC2's `pysc2.bin.agent`: runs an agent class on a map, with PySC2's flags.

    python -m sc2jax.environment.pysc2.bin.agent --map MoveToBeacon \\
        --agent mymodule.MyAgent --max_episodes 10
    python -m sc2jax.environment.pysc2.bin.agent --map Acropolis \\
        --agent mymodule.MyAgent --agent2 Bot --difficulty easy

`--agent` names a class (`module.Class`) with PySC2's `BaseAgent` interface. On a ladder
map the other player is `--agent2`: the simulator's computer ("Bot", at
`--difficulty`) or a second agent class. At the end it prints each episode's score (the
first agent's) and their mean.
"""

from __future__ import annotations

import importlib

from absl import app, flags

from sc2jax.environment.interface.map_names import LADDER_MAPS
from sc2jax.environment.pysc2.env import run_loop, sc2_env
from sc2jax.environment.pysc2.lib import features

FLAGS = flags.FLAGS
flags.DEFINE_string("map", None, "Name of a map to play: a mini-game or a ladder map.")
flags.DEFINE_string("agent", "sc2jax.environment.pysc2.agents.random_agent.RandomAgent",
                    "Which agent to run, as a python path to an agent class.")
flags.DEFINE_enum("agent_race", "random", ["random", "terran"],
                  "The agent's race (the mini-games' player is Terran).")
flags.DEFINE_string("agent_name", None, "Name of the agent in the episode's records.")
flags.DEFINE_integer("feature_screen_size", 84, "Resolution for screen feature layers.")
flags.DEFINE_integer("feature_minimap_size", 64, "Resolution for minimap feature layers.")
flags.DEFINE_bool("use_feature_units", False, "Whether to include feature units.")
flags.DEFINE_bool("use_raw_units", False, "Whether to include raw units.")
flags.DEFINE_enum("action_space", None, ["FEATURES", "RAW"], "Which action space the "
                  "agents use (None: FEATURES; RAW needs --use_raw_units).")
flags.DEFINE_string("agent2", "Bot", "On ladder maps, the second player: Bot (the "
                    "simulator's computer) or an agent class.")
flags.DEFINE_enum("agent2_race", "random", ["random", "terran"], "The second agent's race.")
flags.DEFINE_enum("difficulty", "very_easy", ["very_easy", "easy", "medium", "hard"],
                  "The Bot's difficulty.")
flags.DEFINE_integer("step_mul", 8, "Game steps per agent step.")
flags.DEFINE_integer("game_steps_per_episode", None, "Game steps per episode.")
flags.DEFINE_integer("max_episodes", 0, "Total episodes (0: until interrupted).")
flags.DEFINE_integer("max_agent_steps", 0, "Total agent steps (0: no limit).")
flags.DEFINE_integer("random_seed", None, "The environment's seed.")
flags.DEFINE_bool("render", False, "Whether to render with a viewer (not built yet).")
flags.DEFINE_bool("save_replay", False, "Whether to save a replay at the end (not "
                  "supported by the simulator).")
flags.mark_flag_as_required("map")


def load_agent_class(path: str) -> type:
    """The class `module.Class` names.

    Raises:
      ValueError: the path has no module part, the module does not import, or it has no
        such attribute.
    """
    module_name, _, class_name = path.rpartition(".")
    if not module_name:
        raise ValueError(f"--agent {path!r} must be a python path to a class, like "
                         f"mymodule.MyAgent")
    try:
        module = importlib.import_module(module_name)
    except ImportError as error:
        raise ValueError(f"--agent {path!r}: cannot import {module_name!r}: {error}") from None
    agent_class = getattr(module, class_name, None)
    if not isinstance(agent_class, type):
        found = sorted(n for n in dir(module) if isinstance(getattr(module, n), type))
        raise ValueError(f"--agent {path!r}: {module_name} has no class {class_name!r}; its "
                         f"classes: {found}")
    return agent_class


def main(argv) -> None:
    del argv
    if FLAGS.render or FLAGS.save_replay:
        raise app.UsageError("--render and --save_replay are not supported by the "
                             "simulator (it has no viewer yet, and saves no replays here)")
    agent_class = load_agent_class(FLAGS.agent)
    players = [sc2_env.Agent(sc2_env.Race[FLAGS.agent_race], FLAGS.agent_name)]
    agents = [ScoreKeeper(agent_class())]
    if FLAGS.map in LADDER_MAPS:
        if FLAGS.agent2 == "Bot":
            players.append(sc2_env.Bot(sc2_env.Race.terran,
                                       sc2_env.Difficulty[FLAGS.difficulty]))
        else:
            players.append(sc2_env.Agent(sc2_env.Race[FLAGS.agent2_race]))
            agents.append(load_agent_class(FLAGS.agent2)())
    env = sc2_env.SC2Env(
        map_name=FLAGS.map, players=players,
        agent_interface_format=features.parse_agent_interface_format(
            feature_screen=FLAGS.feature_screen_size,
            feature_minimap=FLAGS.feature_minimap_size, action_space=FLAGS.action_space,
            use_feature_units=FLAGS.use_feature_units, use_raw_units=FLAGS.use_raw_units),
        step_mul=FLAGS.step_mul, game_steps_per_episode=FLAGS.game_steps_per_episode,
        random_seed=FLAGS.random_seed)
    agent = agents[0]
    with env:
        run_loop.run_loop(agents, env, FLAGS.max_agent_steps, FLAGS.max_episodes)
    scores = agent.scores
    if scores:
        print(f"{len(scores)} episodes of {FLAGS.map}: scores {scores}; mean "
              f"{sum(scores) / len(scores):.2f}")


class ScoreKeeper:
    """Passes everything to `agent` and records each finished episode's score (the sum of
    its rewards)."""

    def __init__(self, agent):
        self.agent, self.scores, self._score = agent, [], 0.0

    def setup(self, obs_spec, action_spec) -> None:
        self.agent.setup(obs_spec, action_spec)

    def reset(self) -> None:
        self._score = 0.0
        self.agent.reset()

    def step(self, obs):
        self._score += obs.reward
        if obs.last():
            self.scores.append(self._score)
        return self.agent.step(obs)


if __name__ == "__main__":
    app.run(main)
