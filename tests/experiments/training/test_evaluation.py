"""Evaluation: policies by name, full episodes in one compiled call, the entry point's
flag checks, and the scripted agents playing their maps as a human would."""

import json
import subprocess
import sys

import dm_env
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS, FeatureUnit, ObservationFormat, Simulator
from sc2jax.environment.agents import required_format, scripted_policy
from sc2jax.environment.agents.scripted_economy import DEPOT_SITES, _to_pixel
from sc2jax.environment.engine.compiled import simulator
from sc2jax.environment.episodes import check_replay, load_episode, replay
from sc2jax.environment.interface.observation_tables import Player
from sc2jax.environment.server.install_layout import write_sc2path
from sc2jax.experiments.training import evaluation

FMT = ObservationFormat(32, 32, **required_format("MoveToBeacon"))


def _sim(name="MoveToBeacon") -> Simulator:
    return simulator(name, FMT, 8, 0, 1.0, 1.0, False)


def test_unknown_agent_and_bad_counts_raise():
    with pytest.raises(ValueError, match="unknown agent 'dqn'"):
        evaluation.make_policy("dqn", "MoveToBeacon", _sim().fmt)
    policy = evaluation.make_policy("random", "MoveToBeacon", _sim().fmt)
    for kwargs in ({"episodes": 0}, {"episodes": 2, "num_envs": -1}):
        with pytest.raises(ValueError, match="must be a positive int"):
            evaluation.run_episodes(_sim(), policy, **{"episodes": 1, **kwargs})


def test_scripted_agent_needs_what_it_reads():
    with pytest.raises(ValueError, match="use_feature_units"):
        scripted_policy("MoveToBeacon", ObservationFormat(32, 32))
    with pytest.raises(ValueError, match=r"minimap layers \['visibility_map'\]"):
        scripted_policy("FindAndDefeatZerglings",
                        ObservationFormat(32, 32, minimap_features=("player_relative",
                                                                     "pathable")))
    for name in ("DefeatRoaches", "DefeatZerglingsAndBanelings"):
        with pytest.raises(ValueError, match="use_feature_units"):
            scripted_policy(name, ObservationFormat(32, 32))
    with pytest.raises(ValueError, match="no scripted agent for map 'Nowhere'"):
        scripted_policy("Nowhere", FMT)


def _combat_obs(units, game_loop, res=32):
    """A hand-made observation: `units` rows are (unit id, alliance, x, y, health,
    selected) in screen pixels."""
    rows = np.zeros((8, len(FeatureUnit)), np.int32)
    for i, (kind, alliance, x, y, health, selected) in enumerate(units):
        rows[i, [FeatureUnit.unit_type, FeatureUnit.alliance, FeatureUnit.x, FeatureUnit.y,
                 FeatureUnit.health, FeatureUnit.is_selected]] = (
            kind, alliance, x, y, health, selected)
    return {"feature_units": rows, "feature_screen": np.zeros((1, res, res), np.int32),
            "game_loop": np.array([game_loop], np.int32)}


def test_combat_scripts_focus_fire_and_stutter_step():
    marine, roach, zergling, baneling = 48, 110, 105, 9
    key = None
    # DefeatRoaches: the weakest roach, whatever its distance; select the army first
    # when a marine is not selected.
    obs = _combat_obs([(marine, 1, 5, 16, 45, 1), (marine, 1, 5, 17, 45, 1),
                       (roach, 4, 20, 16, 145, 0), (roach, 4, 28, 16, 40, 0)], 8)
    act = scripted_policy("DefeatRoaches", FMT)(key, obs)
    assert int(act.function) == FUNCTIONS.Attack_screen.id
    assert np.asarray(act.screen).tolist() == [28, 16]
    obs["feature_units"][1, FeatureUnit.is_selected] = 0
    act = scripted_policy("DefeatRoaches", FMT)(key, obs)
    assert int(act.function) == FUNCTIONS.select_army.id
    # DefeatZerglingsAndBanelings: a baneling 3 world units (4 pixels) from the marines:
    # shoot it on even steps, step straight back (away from it) on odd ones.
    policy = scripted_policy("DefeatZerglingsAndBanelings", FMT)
    units = [(marine, 1, 10, 16, 45, 1), (zergling, 4, 12, 20, 35, 0),
             (baneling, 4, 14, 16, 30, 0)]
    act = policy(key, _combat_obs(units, 16))
    assert int(act.function) == FUNCTIONS.Attack_screen.id
    assert np.asarray(act.screen).tolist() == [14, 16]
    act = policy(key, _combat_obs(units, 24))
    assert int(act.function) == FUNCTIONS.Move_screen.id
    x, y = np.asarray(act.screen).tolist()
    assert x < 10 and y == 16
    # Far from every baneling, it keeps shooting.
    far = [(marine, 1, 2, 16, 45, 1)] + units[1:]
    assert int(policy(key, _combat_obs(far, 24)).function) == FUNCTIONS.Attack_screen.id


@pytest.mark.slow
def test_scripted_move_to_beacon_plays_like_a_human():
    # A marine walks 2.25 units per game second: 270 units in the 120 s episode. Beacons
    # lie at least 5 (about 9 on average) apart, so walking straight from beacon to
    # beacon scores about 26 (the paper's DeepMind tester: 26, GrandMaster: 28); the
    # random policy scores about 1.
    stats = evaluation.run_episodes(_sim(), scripted_policy("MoveToBeacon", FMT), episodes=4,
                                    num_envs=4, seed=0)
    assert stats.scores.shape == (4,)
    assert (stats.steps == 240).all()  # The timer ends every episode: 1920 loops / 8.
    assert 20 <= stats.scores.mean() <= 32, stats.scores
    again = evaluation.run_episodes(_sim(), scripted_policy("MoveToBeacon", FMT), episodes=4,
                                    num_envs=4, seed=0)
    np.testing.assert_array_equal(stats.scores, again.scores)  # Same seed, same episodes.


@pytest.mark.slow
def test_the_random_policy_on_an_economy_map_lowers_without_leaking_a_tracer():
    # The map's buildable grid was made a device array inside the step's trace, so the
    # episodes' program kept a tracer and failed to lower ("No constant handler").
    # Lowered, not compiled (the episodes compile for 30-50 s on 2 cores; the contract
    # tests play the map), on every slot (the same game, traced in a third of the time).
    import jax

    sim = simulator("CollectMineralsAndGas", ObservationFormat(16, 16), 64, 0, 1.0, 1.0,
                    False, use_slot_sizes=False)
    policy = evaluation.make_policy("random", "CollectMineralsAndGas", sim.fmt)
    keys = jax.random.split(jax.random.PRNGKey(0), 2)
    with jax.checking_leaks():
        lowered = evaluation._episode_batch(sim, policy, 2).lower(keys)
    assert "while" in lowered.as_text()  # The episodes' scan of 105 steps of 64 loops.


@pytest.mark.slow
def test_evaluate_rejects_bad_flags_before_compiling(tmp_path):
    out = subprocess.run([sys.executable, "-m", "sc2jax.experiments.evaluate", "--map=Nope"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode != 0
    assert "--map='Nope' is unknown; allowed:" in out.stderr
    out = subprocess.run([sys.executable, "-m", "sc2jax.experiments.evaluate",
                          "--episodes=0"], capture_output=True, text=True, timeout=120)
    assert out.returncode != 0 and "--episodes must be >= 1, got 0" in out.stderr
    out = subprocess.run([sys.executable, "-m", "sc2jax.experiments.evaluate",
                          f"--video={tmp_path}", "--video_layers=screen/nope"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode != 0 and "unknown layer 'screen/nope'" in out.stderr


@pytest.mark.slow
def test_evaluate_writes_json(tmp_path):
    path = tmp_path / "eval.json"
    out = subprocess.run(
        [sys.executable, "-m", "sc2jax.experiments.evaluate", "--map=MoveToBeacon",
         "--agent=random", "--episodes=2", "--num_envs=2", "--screen_size=16",
         "--minimap_size=16", "--step_mul=64", f"--output={path}",
         f"--video={tmp_path / 'videos'}", f"--record={tmp_path / 'episodes'}",
         "--video_episodes=2", "--video_width=64"],
        capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    # Two episodes recorded, a GIF of each (31 observations: 30 steps of 64 loops) and a
    # grid; a recorded episode replays to its score.
    import imageio.v3 as iio

    for i in range(2):
        episode = load_episode(tmp_path / "episodes" / f"episode_{i:03d}.npz")
        assert episode.num_steps == 30 and episode.agent == "random"
        check_replay(episode, replay(episode)[1])
        assert iio.imread(tmp_path / "videos" / f"episode_{i:03d}.gif").shape[0] == 31
    assert (tmp_path / "videos" / "grid.gif").exists()
    result = json.loads(path.read_text())
    assert result["episodes"] == 2 and len(result["scores"]) == 2
    assert result["mean"] == pytest.approx(np.mean(result["scores"]))
    assert result["max"] == max(result["scores"])
    assert result["config"]["map"] == "MoveToBeacon"
    assert "Random policy" in out.stdout  # The paper's rows are printed beside.
    # An evaluation in a game process: the simulator's SC2-API server, launched from an
    # install layout as StarCraft II would be.
    root = write_sc2path(tmp_path / "StarCraftII")
    on_game = tmp_path / "eval_sc2.json"
    out = subprocess.run(
        [sys.executable, "-m", "sc2jax.experiments.evaluate", "--map=MoveToBeacon",
         "--agent=random", "--episodes=1", "--num_envs=1", "--screen_size=16",
         "--minimap_size=16", "--step_mul=64", "--backend=sc2", f"--sc2path={root}",
         f"--output={on_game}"],
        capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    game = json.loads(on_game.read_text())
    assert game["episodes"] == 1 and game["config"]["backend"] == "sc2"
    # Both ran MoveToBeacon's whole timer: 1920 game loops, 30 agent steps of 64.
    assert game["steps"] == result["steps"][:1] == [30]


def _economy_obs(units, player, selected=0, last=-1, res=64):
    """A hand-made observation: `units` rows are (unit id, alliance, x, y, build %,
    order length); `player` maps `Player` fields to values; `selected` is the unit id
    selected alone."""
    rows = np.zeros((16, len(FeatureUnit)), np.int32)
    for i, (kind, alliance, x, y, progress, queue) in enumerate(units):
        rows[i, [FeatureUnit.unit_type, FeatureUnit.alliance, FeatureUnit.x, FeatureUnit.y,
                 FeatureUnit.build_progress, FeatureUnit.order_length]] = (
            kind, alliance, x, y, progress, queue)
    vector = np.zeros(11, np.int32)
    for field, value in player.items():
        vector[field] = value
    single = np.zeros((1, 7), np.int32)
    single[0, 0] = selected
    return {"feature_units": rows, "feature_screen": np.zeros((1, res, res), np.int32),
            "player": vector, "single_select": single, "multi_select": np.zeros((4, 7), np.int32),
            "last_actions": np.array([last], np.int32)}


def test_economy_script_sends_idle_workers_builds_supply_and_trains():
    scv, cc, depot, barracks, field = 45, 18, 19, 21, 341
    fmt = ObservationFormat(64, 64, **required_format("BuildMarines"))
    cmag = scripted_policy("CollectMineralsAndGas", fmt)
    units = [(cc, 1, 24, 24, 100, 0), (field, 3, 8, 22, 100, 0), (field, 3, 56, 22, 100, 0),
             (scv, 1, 12, 22, 100, 0), (scv, 1, 30, 30, 100, 0)]
    busy = {Player.minerals: 40, Player.food_used: 12, Player.food_cap: 15,
            Player.food_workers: 12}
    # An idle worker is selected, then sent to the mineral field nearest the CC.
    act = cmag(None, _economy_obs(units, {**busy, Player.idle_worker_count: 1}))
    assert int(act.function) == FUNCTIONS.select_idle_worker.id
    act = cmag(None, _economy_obs(units, busy, selected=scv,
                                  last=FUNCTIONS.select_idle_worker.id))
    assert int(act.function) == FUNCTIONS.Harvest_Gather_screen.id
    assert np.asarray(act.screen).tolist() == [8, 22]
    # With 3 workers per field of the base (24 of an ideal 16), to the far line.
    saturated = _economy_obs(units, busy, selected=scv, last=FUNCTIONS.select_idle_worker.id)
    saturated["feature_units"][0, [FeatureUnit.assigned_harvesters,
                                   FeatureUnit.ideal_harvesters]] = (24, 16)
    act = cmag(None, saturated)
    assert np.asarray(act.screen).tolist() == [56, 22]
    # Supply runs low: an SCV from the mineral line builds a depot at the first site.
    low = {**busy, Player.minerals: 120, Player.food_used: 13}
    act = cmag(None, _economy_obs(units, low))
    assert int(act.function) == FUNCTIONS.select_point.id
    assert np.asarray(act.screen).tolist() == [12, 22]
    act = cmag(None, _economy_obs(units, low, selected=scv))
    assert int(act.function) == FUNCTIONS.Build_SupplyDepot_screen.id
    site = np.asarray(_to_pixel(np.asarray(DEPOT_SITES[0]), 64)).tolist()
    assert np.asarray(act.screen).tolist() == site
    # Enough supply and a 50: an SCV from an idle Command Center.
    rich = {**busy, Player.minerals: 60}
    act = cmag(None, _economy_obs(units, rich))
    assert int(act.function) == FUNCTIONS.select_point.id
    assert np.asarray(act.screen).tolist() == [24, 24]
    act = cmag(None, _economy_obs(units, rich, selected=cc))
    assert int(act.function) == FUNCTIONS.Train_SCV_quick.id
    # BuildMarines, with its 22 SCVs: Marines from every idle Barracks, selected together.
    bm = scripted_policy("BuildMarines", fmt)
    base = units + [(depot, 1, 20, 5, 100, 0), (barracks, 1, 40, 28, 100, 0)]
    marines = {**rich, Player.food_workers: 22, Player.food_cap: 23}
    act = bm(None, _economy_obs(base, marines))
    assert int(act.function) == FUNCTIONS.select_point.id
    assert int(act.select_point_act) == 2 and np.asarray(act.screen).tolist() == [40, 28]
    act = bm(None, _economy_obs(base, marines, selected=barracks))
    assert int(act.function) == FUNCTIONS.Train_Marine_quick.id
    with pytest.raises(ValueError, match="max_units >= 200"):
        scripted_policy("BuildMarines", ObservationFormat(64, 64, use_feature_units=True))


class _Episodes(dm_env.Environment):
    """A batched environment with auto-reset whose environment i has episodes of
    `lengths[i]` steps, each step rewarding 1."""

    def __init__(self, lengths):
        self.lengths = np.array(lengths)
        self.t = np.zeros(len(lengths), int)
        self.actions = []

    def _timestep(self, step_type, reward):
        return dm_env.TimeStep(step_type, reward.astype(np.float32),
                               np.ones(len(self.lengths), np.float32),
                               {"available_actions_mask": np.ones((len(self.lengths), 3), bool)})

    def reset(self):
        self.t[:] = 0
        return self._timestep(np.zeros(len(self.lengths), np.int32), np.zeros(len(self.t)))

    def step(self, action):
        self.actions.append(action)
        restart = self.t == self.lengths
        self.t = np.where(restart, 0, self.t + 1)
        step_type = np.where(restart, 0, np.where(self.t == self.lengths, 2, 1))
        return self._timestep(step_type.astype(np.int32), (~restart).astype(float))

    def observation_spec(self):
        return {}

    def action_spec(self):
        return ()


def test_host_episodes_take_every_environments_episodes_in_turn():
    env = _Episodes([2, 5])
    seen = []

    def act(key, carry, obs, first):
        assert obs["available_actions_mask"].shape == (2, 3) and first.shape == (2,)
        return carry + 1, "action"

    stats = evaluation.run_host_episodes(env, act, 0, 3, on_batch=seen.append)
    # Environment 0 finishes two episodes before environment 1 finishes one; the stats
    # still take the first episode of each before anyone's second.
    np.testing.assert_array_equal(stats.scores, [2, 5, 2])
    np.testing.assert_array_equal(stats.steps, [2, 5, 2])
    assert [s.scores.tolist() for s in seen] == [[2, 5], [2, 5, 2]]
    assert set(env.actions) == {"action"}
    with pytest.raises(ValueError, match="episodes"):
        evaluation.run_host_episodes(env, act, 0, 0)
