"""Replays played back by a game, written in the replay datasets' format.

Where a game answers the StarCraft II API (StarCraft II itself, or sc2jax's server for
its own replays), a replay can be watched as PySC2's `replay_actions` watches it: start
it for one player with feature-layer options, observe every `step_mul` game loops, and
read the player's actions from each observation. A record is then the game's own
observation (feature layers, `player`, `available_actions`), labelled with the first of
the player's actions in the following `step_mul` loops that is a PySC2 function (else
`no_op`), and the player's result as the value (1 for a victory, else 0), in the
records of `dataset.schema`, so converted and played-back datasets are read alike.

    controller = Controller.connect(host, port)     # or `launcher.launch(...)`
    playback_replays(paths, output, Settings(), controller)
"""

from __future__ import annotations

import contextlib
import functools
import os
from collections.abc import Iterator

import numpy as np

from sc2jax.environment.interface.dense import to_dense
from sc2jax.environment.interface.functions import (
    FUNCTIONS,
    FunctionCall,
    validate_function_call,
)
from sc2jax.environment.interface.layout import available_mask
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.environment.sc2api import proto_actions, proto_observation
from sc2jax.environment.sc2api.controller import Controller, RequestError
from sc2jax.environment.sc2api.protos import sc2api
from sc2jax.replay_sl.archive import ReplayError
from sc2jax.replay_sl.dataset import Settings, convert_replays, packed_layers

VICTORY = sc2api.Result.Value("Victory")
_IN_REPLAY, _ENDED = sc2api.Status.Value("in_replay"), sc2api.Status.Value("ended")
_NO_OP = FunctionCall(FUNCTIONS.no_op.id, [])


def interface_options(settings: Settings):
    """The `sc2api.InterfaceOptions` of a playback: feature layers at the settings'
    resolutions, a camera 24 world units wide (PySC2's), and the score."""
    options = sc2api.InterfaceOptions(score=True)
    layers = options.feature_layer
    layers.width = 24
    layers.resolution.x = layers.resolution.y = settings.screen_size
    layers.minimap_resolution.x = layers.minimap_resolution.y = settings.minimap_size
    return options


def label(actions, fmt: ObservationFormat) -> FunctionCall:
    """The first of `sc2api.Action`s that is a valid PySC2 call at `fmt`'s resolutions;
    `no_op` without one."""
    for action in actions:
        call = proto_actions.from_proto(action)
        if call.function == FUNCTIONS.no_op.id:
            continue
        try:
            return validate_function_call(call, fmt.types)
        except ValueError:
            continue
    return _NO_OP


def playback_records(controller: Controller, data: bytes, player_id: int,
                     settings: Settings, *, path: str = "replay") -> Iterator[dict]:
    """Every agent step of one player of a replay, watched in the game, as records.

    Raises:
      ReplayError: if the game cannot play the replay back (`path` names it).
    """
    try:
        info = controller.replay_info(replay_data=data)
        players = {p.player_info.player_id: p for p in info.player_info}
        if player_id not in players:
            raise ReplayError(path, f"no player {player_id}; players {sorted(players)}")
        won = np.float32(players[player_id].player_result.result == VICTORY)
        controller.start_replay(replay_data=data, options=interface_options(settings),
                                observed_player_id=player_id,
                                disable_fog=settings.full_information)
    except RequestError as error:
        raise ReplayError(path, f"the game cannot play it back: {error}") from None
    fmt = ObservationFormat(screen_size=settings.screen_size,
                            minimap_size=settings.minimap_size)
    previous, steps = None, 0
    try:
        game = controller.game_info()
        races = {p.player_id: p.race_requested for p in game.player_info}
        home = races.get(player_id, 0)
        away = next((race for pid, race in races.items() if pid != player_id), 0)
        map_size = (game.start_raw.map_size.x, game.start_raw.map_size.y)
        while True:
            response = controller.observe()
            if previous is not None:
                action = to_dense(label(response.actions, fmt), fmt.types)
                yield {**previous, **{f"action_{name}": np.asarray(value)
                                      for name, value in action._asdict().items()}}
                steps += 1
            if (response.player_result or controller.status == _ENDED
                    or (settings.max_steps is not None and steps >= settings.max_steps)):
                break
            obs = proto_observation.decode(response, fmt, game.map_name, (home, away), True,
                                           map_size)
            previous = {**packed_layers(obs), "player": obs["player"],
                        "available_actions_mask": available_mask(obs["available_actions"]),
                        "game_loop": np.int32(obs["game_loop"][0]), "value": won}
            controller.step(settings.step_mul)
    finally:  # Also when the records are not all read: the game is ready for the next.
        if controller.status in (_IN_REPLAY, _ENDED):
            with contextlib.suppress(RequestError, ConnectionError, TimeoutError):
                controller.leave()


def replay_file_records(path: str | os.PathLike, settings: Settings,
                        controller: Controller) -> Iterator[dict]:
    """Every agent step of every player of a replay file, watched in the game."""
    try:
        data = open(path, "rb").read()
        players = controller.replay_info(replay_data=data).player_info
    except RequestError as error:
        raise ReplayError(path, f"the game cannot read it: {error}") from None
    for player in players:
        if player.player_info.type == sc2api.PlayerType.Value("Participant"):
            yield from playback_records(controller, data, player.player_info.player_id,
                                        settings, path=str(path))


def playback_replays(paths: list[str], output: str | os.PathLike, settings: Settings,
                     controller: Controller, *, log=print) -> dict:
    """`dataset.convert_replays` with the game's playback in place of the decoding: one
    shard per replay, resumable, a replay the game cannot play counted and skipped.

    Returns:
      The summary that `conversion.json` holds.
    """
    return convert_replays(paths, output, settings, log=log, records=functools.partial(
        replay_file_records, controller=controller))
