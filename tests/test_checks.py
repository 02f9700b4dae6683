"""The argument checks shared by the experiment modules."""

from __future__ import annotations

import pytest

from sc2jax.checks import check_known, check_positive_int, non_negative_ints, positive_ints


def test_positive_ints_parses_a_list_flag():
    assert positive_ints("num_envs", ["1", "64", "1024"]) == [1, 64, 1024]


@pytest.mark.parametrize("values", [["1", "a"], ["0"], ["-2"], [], ["1.5"]])
def test_positive_ints_names_the_flag_and_the_bad_value(values):
    with pytest.raises(ValueError, match="--sizes must be a comma-separated list of positive"):
        positive_ints("sizes", values)


def test_non_negative_ints_allow_zero_and_name_the_bad_value():
    assert non_negative_ints("devices", ["1", "0"]) == [1, 0]
    with pytest.raises(ValueError, match=r"--devices must be .* integers >= 0, got '1,-1'"):
        non_negative_ints("devices", ["1", "-1"])


@pytest.mark.parametrize("value", [0, -1, True, 2.0, "3"])
def test_check_positive_int_rejects(value):
    with pytest.raises(ValueError, match="repeats must be a positive int"):
        check_positive_int("repeats", value)


def test_check_known_names_the_unknown_value_and_what_is_allowed():
    check_known("map", ["b", "a"], {"a", "b"})
    with pytest.raises(ValueError, match=r"unknown map 'c'; allowed: \['a', 'b'\]"):
        check_known("map", ["a", "c"], {"b", "a"})


def test_check_not_a_file(tmp_path):
    from sc2jax.checks import check_not_a_file

    check_not_a_file("--run_dir", tmp_path)  # a directory
    check_not_a_file("--run_dir", tmp_path / "new")  # not there yet
    check_not_a_file("--run_dir", None)
    (tmp_path / "f").write_text("")
    with pytest.raises(ValueError, match=r"--run_dir='.*f' is a file; give a directory"):
        check_not_a_file("--run_dir", tmp_path / "f")
