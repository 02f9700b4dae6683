"""Tests for the function table, FunctionCall and validation."""

import pathlib

import numpy as np
import pytest

from sc2jax.environment import (
    FUNCTION_ARGS_MASK,
    FUNCTIONS,
    TYPES,
    FunctionCall,
    FunctionType,
    resolve_types,
    validate_function_call,
)

PACKAGE_TSV = (pathlib.Path(__file__).parents[3] / "sc2jax" / "environment" / "interface"
               / "data" / "pysc2_functions.tsv")
REFERENCE_TSV = (pathlib.Path(__file__).parents[4] / "shared" / "reference"
                 / "pysc2_functions.tsv")


def _reference_rows():
    path = REFERENCE_TSV if REFERENCE_TSV.exists() else PACKAGE_TSV
    lines = [x for x in path.read_text().splitlines() if x and not x.startswith("#")]
    header = lines[0].split("\t")
    return [dict(zip(header, line.split("\t"))) for line in lines[1:]]


def test_package_copy_matches_reference():
    if not REFERENCE_TSV.exists():
        pytest.skip("../shared/reference is not beside this checkout")
    assert PACKAGE_TSV.read_bytes() == REFERENCE_TSV.read_bytes()


def test_table_matches_reference_row_by_row():
    rows = _reference_rows()
    assert len(rows) == len(FUNCTIONS) == 573
    for row, func in zip(rows, FUNCTIONS):
        assert func.id == int(row["id"])
        assert func.name == row["name"]
        assert func.function_type.name == row["function_type"]
        assert [a.name for a in func.args] == [a for a in row["args"].split(",") if a]
        assert func.ability_id == int(row["ability_id"])
        assert func.general_id == int(row["general_id"])


def test_known_rows():
    # Spot checks from PySC2 v4 (and their v1.0 changes).
    assert FUNCTIONS[331].name == "Move_screen" and FUNCTIONS[331].ability_id == 3794
    assert FUNCTIONS[274].name == "HoldPosition_quick" and FUNCTIONS[274].ability_id == 3793
    assert FUNCTIONS[563].name == "Move_Move_screen" and FUNCTIONS[563].general_id == 3794
    assert FUNCTIONS[12].function_type is FunctionType.cmd_screen
    assert [a.name for a in FUNCTIONS.select_rect.args] == ["select_add", "screen", "screen2"]
    assert FUNCTIONS[572].name == "Research_EnhancedShockwaves_quick"


def test_index_by_id_and_name():
    assert FUNCTIONS[331] is FUNCTIONS.Move_screen is FUNCTIONS["Move_screen"]
    assert FUNCTIONS[np.int32(331)] is FUNCTIONS.Move_screen
    assert "Move_screen" in FUNCTIONS and 572 in FUNCTIONS and 573 not in FUNCTIONS
    with pytest.raises(KeyError, match="573"):
        FUNCTIONS[573]
    with pytest.raises(AttributeError, match="Move_Screen"):
        _ = FUNCTIONS.Move_Screen
    assert len(list(FUNCTIONS)) == 573


def test_function_type_counts():
    counts = {}
    for f in FUNCTIONS:
        counts[f.function_type.name] = counts.get(f.function_type.name, 0) + 1
    assert counts["cmd_quick"] == 336
    assert counts["cmd_screen"] == 169
    assert counts["cmd_minimap"] == 35
    assert counts["autocast"] == 21


def test_args_mask():
    assert FUNCTION_ARGS_MASK.shape == (573, 13)
    assert list(np.flatnonzero(FUNCTION_ARGS_MASK[331])) == [TYPES.screen.id, TYPES.queued.id]
    assert not FUNCTION_ARGS_MASK[0].any()


def test_call_with_enum_names():
    call = FUNCTIONS.Move_screen("now", (12, 30))
    assert call == FunctionCall(331, [[0], [12, 30]])
    assert FUNCTIONS.select_point("add_all_type", (1, 2)).arguments == [[3], [1, 2]]
    assert FUNCTIONS.select_control_group("append_and_steal", 9).arguments == [[4], [9]]
    assert FUNCTIONS.select_unit("deselect_all_type", [499]).arguments == [[3], [499]]
    # Float points are floored, as PySC2 does.
    assert FUNCTIONS.Attack_minimap("queued", (3.7, 0.2)).arguments == [[1], [3, 0]]


def test_all_arguments():
    call = FunctionCall.all_arguments(
        FUNCTIONS.Move_screen, {"queued": "queued", "screen": (1, 2), "select_add": 1})
    assert call == FunctionCall(331, [[1], [1, 2]])


@pytest.mark.parametrize("make, pattern", [
    (lambda: FUNCTIONS.Move_screen("now"), r"Move_screen takes 2 arguments"),
    (lambda: FUNCTIONS.no_op(1), r"no_op takes 0 arguments"),
    (lambda: FUNCTIONS.Move_screen("later", (1, 2)), r"'queued' = 'later'.*\['now', 'queued'\]"),
    (lambda: FUNCTIONS.Move_screen(2, (1, 2)), r"'queued' = 2 is outside the allowed range 0\.\.1"),
    (lambda: FUNCTIONS.select_control_group("recall", 10),
     r"select_control_group argument 'control_group_id' = 10 .* 0\.\.9"),
    (lambda: FUNCTIONS.select_point("select", (-1, 3)),
     r"select_point argument 'screen' = \(-1, 3\) is outside"),
    (lambda: FUNCTIONS.Move_screen("now", (1, 2, 3)), r"must be an \(x, y\) point"),
    (lambda: FunctionCall.init_with_validation(573, []), r"unknown function 573"),
    (lambda: FunctionCall.init_with_validation("Fly_screen", []), r"unknown function 'Fly_screen'"),
])
def test_bad_calls_raise(make, pattern):
    with pytest.raises(ValueError, match=pattern):
        make()


def test_validate_point_bounds_against_resolution():
    types = resolve_types(84, (64, 48))
    ok = validate_function_call(FunctionCall(331, [[0], [83, 83]]), types)
    assert ok.arguments == [[0], [83, 83]]
    pattern = r"Move_screen argument 'screen' = \[84, 0\].*x in 0\.\.83"
    with pytest.raises(ValueError, match=pattern):
        validate_function_call(FunctionCall(331, [[0], [84, 0]]), types)
    with pytest.raises(ValueError, match=r"'minimap' = \[0, 48\].*y in 0\.\.47"):
        validate_function_call(FunctionCall(1, [[0, 48]]), types)
    with pytest.raises(ValueError, match=r"'screen2' = \[0, 90\]"):
        validate_function_call(FunctionCall(3, [[0], [0, 0], [0, 90]]), types)
    with pytest.raises(ValueError, match=r"unknown function -1"):
        validate_function_call(FunctionCall(-1, []), types)
    with pytest.raises(ValueError, match=r"Move_screen takes 2 arguments.*got 1"):
        validate_function_call(FunctionCall(331, [[0]]), types)
