"""PySC2's API over the simulator: agents written for PySC2 run with only their imports
changed, observations are named, and what the simulator lacks is refused by name."""

import pathlib
import subprocess
import sys
import types

import numpy as np
import pytest

from sc2jax.environment.pysc2.agents import random_agent
from sc2jax.environment.pysc2.env import run_loop, sc2_env
from sc2jax.environment.pysc2.lib import actions, features, units

AGENTS = pathlib.Path(__file__).with_name("pysc2_agents.py")
ROOT = pathlib.Path(__file__).parents[3]


def pysc2_source() -> str:
    """pysc2_agents.py with its imports changed from `pysc2` to sc2jax's module (the only
    change a PySC2 user makes)."""
    source = AGENTS.read_text()
    assert "from pysc2." in source
    return source.replace("from pysc2.", "from sc2jax.environment.pysc2.")


def load_pysc2_agents():
    module = types.ModuleType("pysc2_agents")
    exec(compile(pysc2_source(), str(AGENTS), "exec"), module.__dict__)
    return module


def _env(map_name, seed, **interface):
    return sc2_env.SC2Env(
        map_name=map_name, players=[sc2_env.Agent(sc2_env.Race.terran)],
        agent_interface_format=features.AgentInterfaceFormat(
            feature_dimensions=features.Dimensions(screen=84, minimap=64), **interface),
        step_mul=8, random_seed=seed)


class _Scores:
    """Wraps an agent and keeps each episode's score."""

    def __init__(self, agent):
        self.agent, self.scores = agent, []

    def setup(self, *specs):
        self.agent.setup(*specs)

    def reset(self):
        self.scores.append(0.0)
        self.agent.reset()

    def step(self, obs):
        self.scores[-1] += obs.reward
        return self.agent.step(obs)


def _play(agent, env, episodes):
    scored = _Scores(agent)
    run_loop.run_loop([scored], env, max_episodes=episodes)
    return scored.scores


@pytest.mark.slow
@pytest.mark.parametrize("name, map_name, interface, low, high", [
    ("MoveToBeacon", "MoveToBeacon", {}, 20, 40),
    ("CollectMineralShards", "CollectMineralShards", {}, 60, 200),
    ("CollectMineralShardsFeatureUnits", "CollectMineralShards",
     {"use_feature_units": True}, 60, 200),
])
def test_pysc2_agents_score_as_in_the_game(name, map_name, interface, low, high):
    # PySC2's own scripted agents scored 24-27 and 80-93 on the game's maps through
    # sc2jax's server (BUILD.md); these are written the same way.
    agent = getattr(load_pysc2_agents(), name)()
    with _env(map_name, seed=3, **interface) as env:
        scores = _play(agent, env, episodes=3)
    assert low <= np.mean(scores) <= high, scores
    assert agent.episodes == 3 and agent.steps == 3 * 241
    assert agent.reward == sum(scores)


@pytest.mark.slow
def test_the_random_agent_scores_as_the_papers_random_policy():
    agent = random_agent.RandomAgent()
    np.random.seed(0)
    with _env("MoveToBeacon", seed=4) as env:
        scores = _play(agent, env, episodes=3)
    assert 0 <= np.mean(scores) <= 5, scores  # The paper's random policy: 1.


@pytest.mark.slow
def test_the_agent_command_runs_a_users_agent_class(tmp_path):
    (tmp_path / "my_agents.py").write_text(pysc2_source())
    result = subprocess.run(
        [sys.executable, "-m", "sc2jax.environment.pysc2.bin.agent", "--map",
         "MoveToBeacon", "--agent", "my_agents.MoveToBeacon", "--max_episodes", "2",
         "--feature_screen_size", "32", "--feature_minimap_size", "32",
         "--random_seed", "1"],
        capture_output=True, text=True, cwd=tmp_path, timeout=600,
        env={"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": ""})
    assert result.returncode == 0, result.stderr[-2000:]
    line = result.stdout.strip().splitlines()[-1]
    assert line.startswith("2 episodes of MoveToBeacon: scores ["), line
    assert float(line.rsplit("mean ", 1)[1]) >= 15
    bad = subprocess.run(
        [sys.executable, "-m", "sc2jax.environment.pysc2.bin.agent", "--map",
         "MoveToBeacon", "--agent", "my_agents.NoSuchAgent"],
        capture_output=True, text=True, cwd=tmp_path, timeout=600,
        env={"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": ""})
    assert bad.returncode != 0
    assert "my_agents has no class 'NoSuchAgent'" in bad.stderr


def test_observations_are_named_and_the_specs_are_pysc2s():
    with sc2_env.SC2Env(
            map_name="MoveToBeacon", players=[sc2_env.Agent(sc2_env.Race.random)],
            agent_interface_format=features.parse_agent_interface_format(
                feature_screen=16, feature_minimap=16, use_feature_units=True),
            random_seed=0) as env:
        (timestep,) = env.reset()
        (obs_spec,), (action_spec,) = env.observation_spec(), env.action_spec()
        obs = timestep.observation
        assert timestep.first() and timestep.reward == 0
        relative = obs.feature_screen.player_relative
        assert relative.shape == (16, 16)
        np.testing.assert_array_equal(
            relative, obs["feature_screen"][features.SCREEN_FEATURES.player_relative.index])
        np.testing.assert_array_equal(relative, obs.feature_screen["player_relative"])
        assert obs["player"].minerals == obs.player[features.Player.minerals]
        assert obs.feature_units.shape[1] == len(features.FeatureUnit)
        beacon = [u for u in obs.feature_units if u.alliance == features.PlayerRelative.NEUTRAL]
        marine = [u for u in obs.feature_units if u.unit_type == units.Terran.Marine]
        assert len(beacon) == 1 and len(marine) == 1
        assert actions.FUNCTIONS.select_army.id in obs.available_actions  # Ids, as PySC2.
        assert obs_spec["feature_screen"] == (27, 16, 16)
        assert obs_spec["available_actions"] == (0,)
        assert obs_spec["feature_units"] == (0, len(features.FeatureUnit))
        assert action_spec.types.screen.sizes == (16, 16)
        assert action_spec.functions[actions.FUNCTIONS.Move_screen.id].args[1].sizes == (16, 16)
        (timestep,) = env.step([actions.FUNCTIONS.select_army("select")])
        assert timestep.mid() and timestep.observation.single_select[0].unit_type == 48


@pytest.mark.parametrize("kwargs, message", [
    (dict(players=[sc2_env.Agent(sc2_env.Race.zerg)]), "the simulator's players are Terran"),
    (dict(players=[sc2_env.Agent(sc2_env.Race.terran),
                   sc2_env.Bot(sc2_env.Race.terran, sc2_env.Difficulty.easy)]),
     "mini-games with one Agent and no Bot"),
    (dict(map_name="Acropolis", players=[sc2_env.Agent(sc2_env.Race.terran),
                                         sc2_env.Bot(sc2_env.Race.zerg, 1)]),
     "the simulator's players are Terran"),
    (dict(map_name="Acropolis", players=[sc2_env.Agent(sc2_env.Race.terran),
                                         sc2_env.Bot(sc2_env.Race.terran, 1,
                                                     sc2_env.BotBuild.rush)]),
     "of build 'random'; got race 'terran', build 'rush'"),
    (dict(map_name="Acropolis", players=[sc2_env.Agent(sc2_env.Race.terran)] * 3),
     "its ladder maps with one Agent, two, or an Agent then a Bot"),
    (dict(players=None), "players is required"),
    (dict(map_name="MoveToBecon"), "MoveToBecon"),
    (dict(visualize=True), "visualize=True: not supported by the simulator"),
    (dict(realtime=True, disable_fog=True), "realtime=True, disable_fog=True"),
    (dict(agent_interface_format=None), "agent_interface_format must be"),
])
def test_settings_the_simulator_lacks_are_refused_by_name(kwargs, message):
    settings = dict(map_name="MoveToBeacon", players=[sc2_env.Agent(sc2_env.Race.terran)],
                    agent_interface_format=features.AgentInterfaceFormat(
                        feature_dimensions=features.Dimensions(screen=16, minimap=16)))
    settings.update(kwargs)
    with pytest.raises(ValueError, match=message):
        sc2_env.SC2Env(**settings)


@pytest.mark.parametrize("make_format, message", [
    (lambda: features.AgentInterfaceFormat(), "feature_dimensions must be"),
    (lambda: features.AgentInterfaceFormat(
        feature_dimensions=features.Dimensions(84, 64), camera_width_world_units=32),
     "camera_width_world_units=32"),
    (lambda: features.AgentInterfaceFormat(
        feature_dimensions=features.Dimensions(84, 64), max_raw_actions=8,
        use_unit_counts=True), "max_raw_actions, use_unit_counts: not supported"),
    (lambda: features.AgentInterfaceFormat(
        feature_dimensions=features.Dimensions(84, 64), action_space=features.ActionSpace.RGB),
     "action_space ActionSpace.RGB"),
    (lambda: features.AgentInterfaceFormat(
        feature_dimensions=features.Dimensions(84, 64), action_space=actions.ActionSpace.RAW),
     "You must set use_raw_units if you intend to use_raw_actions"),
    (lambda: features.Dimensions(screen=8, minimap=64), "screen"),
    (lambda: features.parse_agent_interface_format(feature_screen=84, feature_minimap=64,
                                                   rgb_screen=128), "no RGB"),
])
def test_interface_options_the_simulator_lacks_are_refused_by_name(make_format, message):
    with pytest.raises(ValueError, match=message):
        make_format()


def test_a_raw_agent_moves_its_marine_by_its_raw_units_row():
    with sc2_env.SC2Env(
            map_name="MoveToBeacon", players=[sc2_env.Agent(sc2_env.Race.terran)],
            agent_interface_format=features.AgentInterfaceFormat(
                feature_dimensions=features.Dimensions(screen=16, minimap=16),
                use_raw_units=True, action_space=actions.ActionSpace.RAW),
            random_seed=0) as env:
        (action_spec,), (obs_spec,) = env.action_spec(), env.observation_spec()
        assert action_spec.types.world.sizes == (64, 64)  # The map's size.
        assert action_spec.types.unit_tags.sizes == (30,)  # max_selected_units.
        assert action_spec.functions[actions.RAW_FUNCTIONS.Move_pt.id].args[2].sizes == (64, 64)
        assert "available_actions" not in obs_spec
        (timestep,) = env.reset()
        marine = [i for i, u in enumerate(timestep.observation.raw_units)
                  if u.alliance == features.PlayerRelative.SELF][0]
        x, y = (int(v) for v in timestep.observation.raw_units[marine][["x", "y"]])
        for _ in range(4):
            (timestep,) = env.step([actions.RAW_FUNCTIONS.Move_pt("now", [marine], (x, 10))])
        assert timestep.observation.raw_units[marine].y < y


def test_ladder_maps_take_an_agent_and_a_bot_or_two_agents():
    interface = features.AgentInterfaceFormat(
        feature_dimensions=features.Dimensions(screen=16, minimap=16), use_raw_units=True,
        action_space=actions.ActionSpace.RAW, raw_resolution=88)
    both = sc2_env.SC2Env(map_name="Acropolis", players=[sc2_env.Agent(sc2_env.Race.terran),
                                                         sc2_env.Agent(sc2_env.Race.random)],
                          agent_interface_format=[interface, interface])
    specs = both.action_spec()
    assert len(specs) == len(both.observation_spec()) == 2
    assert specs[0].types.world.sizes == (88, 88)
    assert both._envs["Acropolis"].simulator.score_index == -1  # The outcome, as PySC2's.
    with pytest.raises(ValueError, match="step takes one action per agent"):
        both.step([actions.RAW_FUNCTIONS.no_op()])
    bot = sc2_env.SC2Env(map_name="Acropolis", players=[
        sc2_env.Agent(sc2_env.Race.terran),
        sc2_env.Bot(sc2_env.Race.terran, sc2_env.Difficulty.medium)],
        agent_interface_format=interface)
    assert bot._envs["Acropolis"].simulator.computer == sc2_env.Difficulty.medium
    assert len(bot.action_spec()) == 1


def test_unit_ids_are_blizzards():
    import json
    stable = json.loads((ROOT / "sc2jax/replay_sl/data/stableid.json").read_text())
    ids = {u["id"] for u in stable["Units"]}
    for race in (units.Neutral, units.Protoss, units.Terran, units.Zerg):
        assert {int(u) for u in race} <= ids, race
    assert (units.Terran.Marine, units.Zerg.Zergling, units.Neutral.MineralField) == (48, 105,
                                                                                      341)
    assert units.get_unit_type(48) is units.Terran.Marine
    with pytest.raises(ValueError, match="unit type id 0"):
        units.get_unit_type(0)
