"""Tests for the feature-layer and non-spatial tables."""

import pytest

from sc2jax.environment import (
    MINIMAP_FEATURES,
    SCREEN_FEATURES,
    ControlGroup,
    FeatureType,
    FeatureUnit,
    Player,
    ScoreByCategory,
    ScoreByVital,
    ScoreCategories,
    ScoreCumulative,
    ScoreVitals,
    UnitLayer,
    select_layers,
)

# PySC2 v4 (reference/pysc2_facts.md §1.1, §1.2): name, scale, S(calar)/C(ategorical).
SCREEN = ("height_map 256 S, visibility_map 4 C, creep 2 C, power 2 C, player_id 17 C, "
          "player_relative 5 C, unit_type 1962 C, selected 2 C, unit_hit_points 1600 S, "
          "unit_hit_points_ratio 256 S, unit_energy 1000 S, unit_energy_ratio 256 S, "
          "unit_shields 1000 S, unit_shields_ratio 256 S, unit_density 16 S, "
          "unit_density_aa 256 S, effects 16 C, hallucinations 2 C, cloaked 2 C, blip 2 C, "
          "buffs 290 C, buff_duration 256 S, active 2 C, build_progress 256 S, pathable 2 C, "
          "buildable 2 C, placeholder 2 C")
MINIMAP = ("height_map 256 S, visibility_map 4 C, creep 2 C, camera 2 C, player_id 17 C, "
           "player_relative 5 C, selected 2 C, unit_type 1962 C, alerts 2 C, pathable 2 C, "
           "buildable 2 C")


@pytest.mark.parametrize("table, text", [(SCREEN_FEATURES, SCREEN), (MINIMAP_FEATURES, MINIMAP)])
def test_layers_match_pysc2(table, text):
    rows = [item.split() for item in text.split(", ")]
    assert len(table) == len(rows)
    for index, (feature, (name, scale, kind)) in enumerate(zip(table, rows)):
        assert feature.index == index
        assert feature.name == name
        assert feature.scale == int(scale)
        assert feature.type is (FeatureType.SCALAR if kind == "S" else FeatureType.CATEGORICAL)


def test_counts():
    assert len(SCREEN_FEATURES) == 27 and len(MINIMAP_FEATURES) == 11


def test_select_layers():
    layers = select_layers(SCREEN_FEATURES, ["selected", "player_relative"])
    assert [f.index for f in layers] == [7, 5]
    assert select_layers(MINIMAP_FEATURES, None) == tuple(MINIMAP_FEATURES)
    with pytest.raises(ValueError, match="unknown screen layer 'camera'"):
        select_layers(SCREEN_FEATURES, ["camera"])
    with pytest.raises(ValueError, match="repeat"):
        select_layers(MINIMAP_FEATURES, ["camera", "camera"])
    with pytest.raises(ValueError, match="no minimap layers"):
        select_layers(MINIMAP_FEATURES, [])
    with pytest.raises(ValueError, match="string 'camera'"):
        select_layers(MINIMAP_FEATURES, "camera")


def test_non_spatial_tables():
    assert len(Player) == 11 and Player.idle_worker_count == 7 and Player.larva_count == 10
    assert len(ScoreCumulative) == 13 and ScoreCumulative.collected_minerals == 7
    assert (len(ScoreByCategory), len(ScoreCategories)) == (11, 5)
    assert ScoreByCategory.total_used_vespene == 10 and ScoreCategories.upgrade == 4
    assert (len(ScoreByVital), len(ScoreVitals)) == (3, 3)
    assert len(UnitLayer) == 7 and UnitLayer.build_progress == 6
    assert len(ControlGroup) == 2
    assert len(FeatureUnit) == 46
    assert FeatureUnit.tag == 29 and FeatureUnit.is_on_screen == 35
    assert FeatureUnit.shield_upgrade_level == 45
