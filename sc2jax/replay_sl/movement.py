"""How units move, for placing them between the tracker's reports: each type's speed,
and a straight walk towards an order's target.

Speeds are the game's base movement speeds at Faster (world units per real second,
Liquipedia's figures; the API's Normal-speed values times 1.4), without upgrades
(Stimpack, Metabolic Boost, Charge, Glial Reconstitution...) and without creep. A type
not listed does not move when ordered: structures (a rally point moves nothing), sieged
and burrowed units, larvae and eggs. Lifted Terran structures fly.
"""

from __future__ import annotations

import functools
import math

from sc2jax.replay_sl.units import stable_unit_ids

LOOPS_PER_SECOND = 22.4
"""Game loops per real second at Faster."""

FASTER_SPEEDS = {
    # Terran.
    "SCV": 3.94, "MULE": 3.94, "Marine": 3.15, "Marauder": 3.15, "Reaper": 5.25,
    "Ghost": 3.94, "Hellion": 5.95, "HellionTank": 3.15, "WidowMine": 3.94,
    "SiegeTank": 3.15, "Cyclone": 4.72, "Thor": 2.62, "ThorAP": 2.62,
    "VikingFighter": 3.85, "VikingAssault": 3.15, "Medivac": 3.5, "Liberator": 4.72,
    "Raven": 3.85, "Banshee": 3.85, "Battlecruiser": 2.62,
    "BarracksFlying": 1.4, "FactoryFlying": 1.4, "StarportFlying": 1.4,
    "CommandCenterFlying": 1.4, "OrbitalCommandFlying": 1.4,
    # Protoss.
    "Probe": 3.94, "Zealot": 3.15, "Stalker": 4.13, "Sentry": 3.15, "Adept": 3.5,
    "HighTemplar": 2.62, "DarkTemplar": 3.94, "Archon": 3.94, "Observer": 2.63,
    "WarpPrism": 4.13, "Immortal": 3.15, "Colossus": 3.15, "Disruptor": 3.15,
    "Phoenix": 5.95, "VoidRay": 3.85, "Oracle": 5.6, "Tempest": 3.15, "Carrier": 2.62,
    "Mothership": 2.62,
    # Zerg.
    "Drone": 3.94, "Zergling": 4.13, "Baneling": 3.5, "Roach": 3.15, "Ravager": 3.85,
    "Hydralisk": 3.15, "LurkerMP": 4.13, "Infestor": 3.15, "SwarmHostMP": 3.15,
    "Ultralisk": 4.13, "Queen": 1.31, "Overlord": 0.902, "OverlordTransport": 0.902,
    "Overseer": 2.62, "Mutalisk": 5.6, "Corruptor": 4.725, "BroodLord": 1.97,
    "Viper": 4.13, "Changeling": 3.15,
}
"""Unit name (stableid.json) -> base speed at Faster, world units per real second."""


@functools.cache
def speeds_by_id() -> dict[int, float]:
    """Stable unit id -> speed in world units per game loop (types that move only)."""
    ids = stable_unit_ids()
    return {ids[name]: speed / LOOPS_PER_SECOND for name, speed in FASTER_SPEEDS.items()}


def speed(unit_type: int) -> float:
    """World units per game loop of a stable unit id; 0 for a type that does not move."""
    return speeds_by_id().get(int(unit_type), 0.0)


def walk(start: tuple[float, float], target: tuple[float, float], speed_: float,
         loops: float) -> tuple[float, float]:
    """Where a unit at `start` is after walking `loops` game loops straight towards
    `target` at `speed_` world units a loop (at `target` once there)."""
    dx, dy = target[0] - start[0], target[1] - start[1]
    distance = math.hypot(dx, dy)
    step = speed_ * loops
    if step >= distance:
        return float(target[0]), float(target[1])
    return start[0] + dx / distance * step, start[1] + dy / distance * step
