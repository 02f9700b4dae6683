"""A replay's metadata: map, build, length, and its players apart from the observers.

Players are the details' player list, in order (player ids 1, 2, ...). Each is matched
to its game-event user id through its lobby slot (`m_workingSetSlotId`), or, where the
details name no slot, through the tracker's PlayerSetup event; every other user in the
lobby (observers, casters) is left out. Races come from the lobby's
attributes (the details' race strings are in the recording client's language); a random
pick's race is read from the first town hall or worker the player owns.
"""

from __future__ import annotations

import dataclasses
import html

from sc2jax.replay_sl.archive import Replay, ReplayError

RACE_ATTRIBUTE = 3001
"""The lobby attribute that holds a player's race ("Terr", "Zerg", "Prot" or "RAND")."""
RACES = {b"Terr": "Terran", b"Zerg": "Zerg", b"Prot": "Protoss"}
RESULTS = {0: "Undecided", 1: "Win", 2: "Loss", 3: "Tie"}
_RACE_OF_UNIT = {b"CommandCenter": "Terran", b"SCV": "Terran", b"Hatchery": "Zerg",
                 b"Drone": "Zerg", b"Nexus": "Protoss", b"Probe": "Protoss"}


@dataclasses.dataclass(frozen=True)
class Player:
    """One player of a replay.

    Attributes:
      player_id: 1-based, as tracker events and PySC2 name players.
      user_id: the id of this player's game events.
      name: the player's name (HTML entities of the file decoded).
      race: "Terran", "Zerg" or "Protoss".
      result: "Win", "Loss", "Tie" or "Undecided".
    """

    player_id: int
    user_id: int
    name: str
    race: str
    result: str


@dataclasses.dataclass(frozen=True)
class ReplayMetadata:
    """What `replay_info` prints.

    Attributes:
      map_name: the map's title.
      base_build: the game's base build; version: the full version string.
      game_loops: the length in game loops.
      players: the players (observers excluded), by player id.
      observer_user_ids: the user ids of everyone else in the lobby.
    """

    map_name: str
    base_build: int
    version: str
    game_loops: int
    players: tuple[Player, ...]
    observer_user_ids: tuple[int, ...]

    def player(self, player_id: int) -> Player:
        """The player with this id; ValueError naming the ids there are."""
        for p in self.players:
            if p.player_id == player_id:
                return p
        raise ValueError(f"player {player_id!r} is not in this replay; its players are "
                         f"{[p.player_id for p in self.players]}")

    def to_json(self) -> dict:
        return {"map": self.map_name, "base_build": self.base_build,
                "game_loops": self.game_loops,
                "players": [{"player_id": p.player_id, "name": p.name, "race": p.race,
                             "result": p.result} for p in self.players]}


def clean_name(raw: bytes) -> str:
    """A player name as the file stores it (HTML-escaped, `<sp/>` for spaces) -> text."""
    return html.unescape(raw.decode("utf-8", "replace").replace("<sp/>", " "))


def read_metadata(replay: Replay) -> ReplayMetadata:
    """The replay's map, build, length and players.

    Raises:
      ReplayError: if a player has no lobby slot or user, or an unknown race.
    """
    slots = replay.initdata["m_syncLobbyState"]["m_lobbyState"]["m_slots"]
    user_of_slot = {s["m_workingSetSlotId"]: s["m_userId"] for s in slots}
    scopes = replay.attributes.get("scopes", {})
    players, random_race = [], []
    setup = None
    for index, entry in enumerate(replay.details["m_playerList"]):
        player_id = index + 1
        user_id = user_of_slot.get(entry["m_workingSetSlotId"])
        if user_id is None:  # No working-set slot: the tracker's player setup names it.
            setup = _player_setup(replay) if setup is None else setup
            user_id = setup.get(player_id)
        if user_id is None:
            raise ReplayError(replay.path, f"player {player_id} has no user in the lobby")
        code = next((a["value"] for a in scopes.get(player_id, {}).get(RACE_ATTRIBUTE, [])),
                    None)
        race = RACES.get(code)
        if race is None:
            random_race.append(player_id)
        players.append(Player(player_id, int(user_id), clean_name(entry["m_name"]), race or "",
                              RESULTS.get(entry["m_result"], "Undecided")))
    if random_race:
        found = _races_from_units(replay, set(random_race))
        for i, p in enumerate(players):
            if p.player_id in random_race:
                if p.player_id not in found:
                    raise ReplayError(replay.path, f"player {p.player_id}'s race is unknown")
                players[i] = dataclasses.replace(p, race=found[p.player_id])
    player_users = {p.user_id for p in players}
    observers = sorted(s["m_userId"] for s in slots
                       if s["m_userId"] is not None and s["m_userId"] not in player_users)
    return ReplayMetadata(map_name=replay.details["m_title"].decode("utf-8", "replace"),
                          base_build=replay.base_build, version=replay.version,
                          game_loops=replay.game_loops, players=tuple(players),
                          observer_user_ids=tuple(observers))


def _player_setup(replay: Replay) -> dict[int, int]:
    """Player id -> user id from the tracker's PlayerSetup events (at the first loop)."""
    users = {}
    for event in replay.tracker_events():
        if event["_gameloop"] > 0:
            break
        if event["_event"] == "NNet.Replay.Tracker.SPlayerSetupEvent":
            users[event["m_playerId"]] = event["m_userId"]
    return users


def _races_from_units(replay: Replay, player_ids: set[int]) -> dict[int, str]:
    found = {}
    for event in replay.tracker_events():
        if event["_event"] == "NNet.Replay.Tracker.SUnitBornEvent":
            race = _RACE_OF_UNIT.get(event["m_unitTypeName"])
            owner = event["m_controlPlayerId"]
            if race and owner in player_ids and owner not in found:
                found[owner] = race
                if len(found) == len(player_ids):
                    break
    return found
