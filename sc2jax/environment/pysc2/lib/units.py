"""PySC2's `pysc2.lib.units`: unit type ids by race (`units.Terran.Marine` is 48), the
values of the `unit_type` layer and of `FeatureUnit.unit_type`.

The ids are Blizzard's stable unit ids (stableid.json); names follow the game's, with
PySC2's names where they differ (`Hellbat`, `Lurker`, `SwarmHost`, ...).
"""

import enum

__all__ = ["Neutral", "Protoss", "Terran", "Zerg", "get_unit_type"]


class Neutral(enum.IntEnum):
    """Neutral unit types."""

    BattleStationMineralField = 886
    BattleStationMineralField750 = 887
    CarrionBird = 322
    CleaningBot = 612
    CollapsibleRockTower = 609
    CollapsibleRockTowerDebris = 490
    CollapsibleRockTowerDebrisRampLeft = 518
    CollapsibleRockTowerDebrisRampRight = 517
    CollapsibleTerranTower = 610
    CollapsibleTerranTowerDebris = 485
    DebrisRampLeft = 486
    DebrisRampRight = 487
    DestructibleDebris6x6 = 365
    DestructibleDebrisRampDiagonalHugeBLUR = 377
    DestructibleDebrisRampDiagonalHugeULBR = 376
    DestructibleRock6x6 = 371
    DestructibleRockEx14x4 = 638
    DestructibleRockEx16x6 = 639
    DestructibleRockEx1DiagonalHugeBLUR = 641
    DestructibleRockEx1DiagonalHugeULBR = 640
    DestructibleRockEx1HorizontalHuge = 643
    DestructibleRockEx1VerticalHuge = 642
    Dog = 336
    KarakFemale = 324
    LabBot = 661
    LabMineralField = 665
    LabMineralField750 = 666
    Lyote = 321
    MineralField = 341
    MineralField750 = 483
    ProtossVespeneGeyser = 608
    PurifierMineralField = 884
    PurifierMineralField750 = 885
    PurifierRichMineralField = 796
    PurifierRichMineralField750 = 797
    PurifierVespeneGeyser = 880
    ReptileCrate = 877
    RichMineralField = 146
    RichMineralField750 = 147
    RichVespeneGeyser = 344
    Scantipede = 335
    ShakurasVespeneGeyser = 881
    SpacePlatformGeyser = 343
    UnbuildableBricksDestructible = 473
    UnbuildablePlatesDestructible = 474
    UnbuildableRocksDestructible = 472
    UtilityBot = 330
    VespeneGeyser = 342
    XelNagaTower = 149


class Protoss(enum.IntEnum):
    """Protoss unit types."""

    Adept = 311
    AdeptPhaseShift = 801
    Archon = 141
    Assimilator = 61
    Carrier = 79
    Colossus = 4
    CyberneticsCore = 72
    DarkShrine = 69
    DarkTemplar = 76
    Disruptor = 694
    DisruptorPhased = 733
    FleetBeacon = 64
    ForceField = 135
    Forge = 63
    Gateway = 62
    HighTemplar = 75
    Immortal = 83
    Interceptor = 85
    Mothership = 10
    MothershipCore = 488
    Nexus = 59
    Observer = 82
    ObserverSurveillanceMode = 1911
    Oracle = 495
    Phoenix = 78
    PhotonCannon = 66
    Probe = 84
    Pylon = 60
    PylonOvercharged = 894
    RoboticsBay = 70
    RoboticsFacility = 71
    Sentry = 77
    ShieldBattery = 1910
    Stalker = 74
    Stargate = 67
    StasisTrap = 732
    Tempest = 496
    TemplarArchive = 68
    TwilightCouncil = 65
    VoidRay = 80
    WarpGate = 133
    WarpPrism = 81
    WarpPrismPhasing = 136
    Zealot = 73


class Terran(enum.IntEnum):
    """Terran unit types."""

    Armory = 29
    AutoTurret = 31
    Banshee = 55
    Barracks = 21
    BarracksFlying = 46
    BarracksReactor = 38
    BarracksTechLab = 37
    Battlecruiser = 57
    Bunker = 24
    CommandCenter = 18
    CommandCenterFlying = 36
    Cyclone = 692
    EngineeringBay = 22
    Factory = 27
    FactoryFlying = 43
    FactoryReactor = 40
    FactoryTechLab = 39
    FusionCore = 30
    Ghost = 50
    GhostAcademy = 26
    GhostAlternate = 144
    GhostNova = 145
    Hellbat = 484
    Hellion = 53
    KD8Charge = 830
    Liberator = 689
    LiberatorAG = 734
    MULE = 268
    Marauder = 51
    Marine = 48
    Medivac = 54
    MissileTurret = 23
    OrbitalCommand = 132
    OrbitalCommandFlying = 134
    PlanetaryFortress = 130
    PointDefenseDrone = 11
    Raven = 56
    Reactor = 6
    Reaper = 49
    Refinery = 20
    SCV = 45
    SensorTower = 25
    SiegeTank = 33
    SiegeTankSieged = 32
    Starport = 28
    StarportFlying = 44
    StarportReactor = 42
    StarportTechLab = 41
    SupplyDepot = 19
    SupplyDepotLowered = 47
    TechLab = 5
    Thor = 52
    ThorHighImpactMode = 691
    VikingAssault = 34
    VikingFighter = 35
    WidowMine = 498
    WidowMineBurrowed = 500


class Zerg(enum.IntEnum):
    """Zerg unit types."""

    Baneling = 9
    BanelingBurrowed = 115
    BanelingCocoon = 8
    BanelingNest = 96
    BroodLord = 114
    BroodLordCocoon = 113
    Broodling = 289
    BroodlingEscort = 143
    Changeling = 12
    ChangelingMarine = 15
    ChangelingMarineShield = 14
    ChangelingZealot = 13
    ChangelingZergling = 17
    ChangelingZerglingWings = 16
    Cocoon = 103
    Corruptor = 112
    CreepTumor = 87
    CreepTumorBurrowed = 137
    CreepTumorQueen = 138
    Drone = 104
    DroneBurrowed = 116
    EvolutionChamber = 90
    Extractor = 88
    GreaterSpire = 102
    Hatchery = 86
    Hive = 101
    Hydralisk = 107
    HydraliskBurrowed = 117
    HydraliskDen = 91
    InfestationPit = 94
    InfestedTerran = 898
    InfestedTerranCocoon = 150
    Infestor = 111
    InfestorBurrowed = 127
    Lair = 100
    Larva = 151
    Locust = 489
    LocustFlying = 693
    Lurker = 502
    LurkerBurrowed = 503
    LurkerCocoon = 501
    LurkerDen = 504
    Mutalisk = 108
    NydusCanal = 142
    NydusNetwork = 95
    Overlord = 106
    OverlordTransport = 893
    OverlordTransportCocoon = 892
    Overseer = 129
    OverseerOversightMode = 1912
    ParasiticBombDummy = 824
    Queen = 126
    QueenBurrowed = 125
    Ravager = 688
    RavagerBurrowed = 690
    RavagerCocoon = 687
    Roach = 110
    RoachBurrowed = 118
    RoachWarren = 97
    SpawningPool = 89
    SpineCrawler = 98
    SpineCrawlerUprooted = 139
    Spire = 92
    SporeCrawler = 99
    SporeCrawlerUprooted = 140
    SwarmHost = 494
    SwarmHostBurrowed = 493
    Ultralisk = 109
    UltraliskBurrowed = 131
    UltraliskCavern = 93
    Viper = 499
    Zergling = 105
    ZerglingBurrowed = 119

def get_unit_type(unit_id: int) -> enum.IntEnum:
    """The race enum member of `unit_id`.

    Raises:
      ValueError: for an id none of the races has.
    """
    for race in (Neutral, Protoss, Terran, Zerg):
        try:
            return race(unit_id)
        except ValueError:
            pass
    raise ValueError(f"unit type id {unit_id!r} is not a unit of any race here")
