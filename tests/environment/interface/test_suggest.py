"""Mistyped names get their close matches in the error."""

import pytest

from sc2jax.environment.interface.map_names import check_map
from sc2jax.environment.interface.suggest import did_you_mean


def test_close_names_are_suggested_and_far_ones_are_not():
    assert did_you_mean("Move_scren", ["Move_screen", "no_op"]) == "; did you mean Move_screen?"
    assert did_you_mean("xyz", ["Move_screen", "no_op"]) == ""
    with pytest.raises(ValueError, match="unknown map 'MoveToBecon'; the simulator has .*; "
                                         "did you mean MoveToBeacon\\?"):
        check_map("MoveToBecon")
