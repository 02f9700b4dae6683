"""GameEnv's episode logic against a scripted stand-in for the game (no process, no JAX):
the full game's flow with a bot, outcome rewards, truncation as a tie, the end-of-game
stub observation, and replays."""

import dm_env
import numpy as np
import pytest

from sc2jax.environment.interface.dense import to_dense
from sc2jax.environment.interface.functions import FUNCTIONS
from sc2jax.environment.sc2api.game_env import END_OF_GAME_LOOP, Bot, GameEnv, GameEnvBatch
from sc2jax.environment.sc2api.protos import sc2api

IN_GAME, ENDED = sc2api.Status.Value("in_game"), sc2api.Status.Value("ended")


class ScriptedGame:
    """Answers a Controller's calls; the game ends at `end_loop` with `result`."""

    def __init__(self, end_loop=None, result=1, stub=False):
        self.end_loop, self.result, self.stub = end_loop, result, stub
        self.calls, self.loop, self.status = [], 0, None

    def create_game(self, **kwargs):
        self.calls.append(("create_game", kwargs))

    def join_game(self, options, race):
        self.calls.append(("join_game", race))
        self.loop, self.status = 0, IN_GAME

    def restart(self):
        self.calls.append(("restart", None))
        self.loop, self.status = 0, IN_GAME

    def leave(self):
        self.calls.append(("leave", None))

    def game_info(self):
        info = sc2api.ResponseGameInfo(map_name="Simple64")
        info.player_info.add(player_id=1, type=1, race_requested=1)
        info.player_info.add(player_id=2, type=2, race_requested=2)
        return info

    def actions(self, actions):
        self.calls.append(("actions", len(actions)))

    def step(self, count):
        self.loop += count
        if self.end_loop is not None and self.loop >= self.end_loop:
            self.status = ENDED

    def observe(self):
        response = sc2api.ResponseObservation()
        response.observation.game_loop = self.loop
        response.observation.player_common.minerals = self.loop  # Tells steps apart.
        if self.status == ENDED:
            response.player_result.add(player_id=1, result=self.result)
            if self.stub:
                response.observation.game_loop = END_OF_GAME_LOOP
        return response

    def save_replay(self):
        return b"a replay"

    def quit(self):
        self.calls.append(("quit", None))


def _env(game, **kwargs):
    return GameEnv(lambda: game, "Simple64", screen_size=16, minimap_size=16, **kwargs)


def test_the_full_game_against_a_bot_rewards_the_outcome_and_saves_replays(tmp_path):
    game = ScriptedGame(end_loop=24, result=sc2api.Result.Value("Victory"))
    env = _env(game, bot=Bot("zerg", "easy", "rush"), save_replay_episodes=1,
               replay_dir=tmp_path)
    first = env.reset()
    create = game.calls[0][1]
    assert [p.type for p in create["players"]] == [1, 2]
    bot = create["players"][1]
    assert (bot.race, bot.difficulty, bot.ai_build) == (2, 2, 2)
    assert first.observation["home_race_requested"].tolist() == [1]
    assert first.observation["away_race_requested"].tolist() == [2]
    assert first.observation["map_name"] == "Simple64"
    rewards = []
    timestep = first
    while not timestep.last():
        timestep = env.step(FUNCTIONS.no_op())
        rewards.append(timestep.reward)
    assert rewards == [0.0, 0.0, 1.0] and timestep.discount == 0.0
    assert [p.read_bytes() for p in tmp_path.iterdir()] == [b"a replay"]
    assert env.step(FUNCTIONS.no_op()).first()
    # With a bot, a new episode leaves the game and creates it again.
    assert [c[0] for c in game.calls[-3:]] == ["leave", "create_game", "join_game"]
    env.close()
    assert game.calls[-1][0] == "quit"


def test_truncation_is_a_tie_with_the_discount_kept():
    env = _env(ScriptedGame(), game_steps_per_episode=16)
    assert env.reset().first()
    assert env.step(FUNCTIONS.no_op()).mid()
    last = env.step(FUNCTIONS.no_op())
    assert last.last() and last.reward == 0.0 and last.discount == 1.0


def test_the_end_of_game_stub_repeats_the_last_observation():
    game = ScriptedGame(end_loop=16, result=sc2api.Result.Value("Defeat"), stub=True)
    env = _env(game)
    env.reset()
    before = env.step(FUNCTIONS.no_op())
    last = env.step(FUNCTIONS.no_op())
    assert last.last() and last.reward == -1.0
    np.testing.assert_array_equal(last.observation["game_loop"],
                                  before.observation["game_loop"])
    # Without a bot, a new episode restarts the game.
    env.step(FUNCTIONS.no_op())
    assert game.calls[-1][0] == "restart"


def test_unavailable_actions_and_bad_actions_are_rejected():
    env = _env(ScriptedGame())
    env.reset()
    with pytest.raises(ValueError, match="Attack_screen is not available"):
        env.step(FUNCTIONS.Attack_screen("now", (3, 3)))
    with pytest.raises(ValueError, match="outside the allowed range"):
        env.step(FUNCTIONS.move_camera((99, 3)))
    with pytest.raises(TypeError, match="FunctionCall or a DenseAction"):
        env.step("no_op")


def test_a_batch_of_games_steps_them_together_in_the_padded_layout():
    games = [ScriptedGame(end_loop=16), ScriptedGame()]
    batch = GameEnvBatch([_env(game) for game in games])
    first = batch.reset()
    assert first.step_type.tolist() == [dm_env.StepType.FIRST] * 2
    assert first.observation["available_actions_mask"].shape == (2, len(FUNCTIONS))
    assert first.observation["last_actions"].tolist() == [[-1] * 4] * 2
    noop = to_dense([FUNCTIONS.no_op(), FUNCTIONS.no_op()])
    batch.step(noop)
    second = batch.step(noop)
    assert second.step_type.tolist() == [dm_env.StepType.LAST, dm_env.StepType.MID]
    assert batch.step(noop).step_type.tolist() == [dm_env.StepType.FIRST, dm_env.StepType.MID]
    with pytest.raises(ValueError, match="share one observation format"):
        GameEnvBatch([_env(ScriptedGame()), GameEnv(lambda: None, "Simple64",
                                                     screen_size=32)])
