"""PySC2 v4's raw functions (`RAW_FUNCTIONS`, `RAW_TYPES`): the table's size, ids,
names, argument types and abilities, checked against the feature functions' table, and
the validation of raw calls."""

import pytest

from sc2jax.environment.interface.arguments import RAW_TYPES
from sc2jax.environment.interface.functions import (
    FUNCTIONS,
    RAW_FUNCTIONS,
    FunctionCall,
    FunctionType,
)

R = RAW_FUNCTIONS
ARGS = {FunctionType.raw_no_op: (), FunctionType.raw_move_camera: ("world",),
        FunctionType.raw_cmd: ("queued", "unit_tags"),
        FunctionType.raw_cmd_pt: ("queued", "unit_tags", "world"),
        FunctionType.raw_cmd_unit: ("queued", "unit_tags", "target_unit_tag"),
        FunctionType.raw_autocast: ("unit_tags",)}


def test_the_table_is_pysc2_v4s():
    assert len(R) == 564 and [f.id for f in R] == list(range(564))
    assert RAW_TYPES._fields == ("world", "queued", "unit_tags", "target_unit_tag")
    assert [t.id for t in RAW_TYPES] == [0, 1, 2, 3]
    known = {0: ("no_op", 0), 1: ("Smart_pt", 1), 2: ("Attack_pt", 3674),
             3: ("Attack_unit", 3674), 102: ("Harvest_Gather_unit", 3666),
             168: ("raw_move_camera", 0), 222: ("Build_SupplyDepot_pt", 319),
             341: ("Effect_Stim_quick", 3675), 511: ("Train_Marine_quick", 560)}
    for i, (name, ability) in known.items():
        assert (R[i].name, R[i].ability_id) == (name, ability)
    counts = {t: sum(f.function_type == t for f in R) for t in ARGS}
    assert counts == {FunctionType.raw_no_op: 1, FunctionType.raw_move_camera: 1,
                      FunctionType.raw_cmd: 343, FunctionType.raw_cmd_pt: 126,
                      FunctionType.raw_cmd_unit: 72, FunctionType.raw_autocast: 21}
    for f in R:
        assert tuple(a.name for a in f.args) == ARGS[f.function_type], f.name


def test_each_raw_ability_is_a_feature_functions():
    abilities = {f.ability_id for f in FUNCTIONS} | {f.general_id for f in FUNCTIONS}
    missing = sorted(f.name for f in R if f.ability_id and f.ability_id not in abilities)
    # PySC2's feature functions have no UnloadUnit (the raw table's 556-562).
    assert missing == sorted(f.name for f in R if f.name.startswith("UnloadUnit"))
    assert len(missing) == 7
    # Every other raw command has a feature function of its ability named alike
    # (Attack_pt, Attack_unit and Attack_screen: "Attack").
    stem = lambda name: name.rsplit("_", 1)[0]  # noqa: E731
    feature = {(f.ability_id, stem(f.name)) for f in FUNCTIONS}
    unlike = [f.name for f in R if f.ability_id and (f.ability_id, stem(f.name)) not in feature]
    assert unlike == [f.name for f in R if f.name.startswith("UnloadUnit")]


def test_raw_calls_are_validated():
    assert R.Attack_pt("now", [5, 6], (10.5, 3)) == FunctionCall(2, [[0], [5, 6], [10, 3]])
    assert R.Train_Marine_quick("queued", 7) == FunctionCall(511, [[1], [7]])
    assert R.Attack_unit(0, [1], 9) == FunctionCall(3, [[0], [1], [9]])
    with pytest.raises(ValueError, match=r"'queued' = 'soon' is not allowed; expected one "
                                         r"of \['now', 'queued'\]"):
        R.Attack_pt("soon", [1], (1, 1))
    with pytest.raises(ValueError, match=r"'unit_tags' = \[\] must be 1 to 512 unit tags"):
        R.Attack_pt("now", [], (1, 1))
    with pytest.raises(ValueError, match="'target_unit_tag' = .* must be a unit tag"):
        R.Attack_unit("now", [1], [1, 2])
    with pytest.raises(ValueError, match=r"'world' = \(-1, 2\) is outside"):
        R.Attack_pt("now", [1], (-1, 2))
    with pytest.raises(ValueError, match="Attack_pt takes 3 arguments"):
        R.Attack_pt("now", [1])
