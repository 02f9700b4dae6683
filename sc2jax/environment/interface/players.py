"""The SC2 API's player settings by PySC2's names (`pysc2.env.sc2_env`): races, built-in
AI difficulties and builds, with the API's values (`common.proto` Race, `sc2api.proto`
Difficulty and AIBuild)."""

import enum


class Race(enum.IntEnum):
    random = 4
    protoss = 3
    terran = 1
    zerg = 2


class Difficulty(enum.IntEnum):
    very_easy = 1
    easy = 2
    medium = 3
    medium_hard = 4
    hard = 5
    harder = 6
    very_hard = 7
    cheat_vision = 8
    cheat_money = 9
    cheat_insane = 10


class BotBuild(enum.IntEnum):
    random = 1
    rush = 2
    timing = 3
    power = 4
    macro = 5
    air = 6
