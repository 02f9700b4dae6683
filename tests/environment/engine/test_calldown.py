"""The Orbital Command's Calldown: MULE (`calldown`) on CollectMineralsAndGas: the MULE
called down on a mineral field or the ground for 50 energy, harvesting, and dying after
its 64 seconds."""

import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS
from sc2jax.environment.engine.minigames.economy import COMMAND_CENTER, LEFT_FIELDS
from sc2jax.environment.engine.rules import calldown
from sc2jax.environment.engine.rules.state import Order
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.interface.protocol_enums import ActionResult

from .test_production import act, available, pixel, result, select_cc, slots, start, wait

F = FUNCTIONS


def orbital(energy):
    """CollectMineralsAndGas's first state with its Command Center an Orbital Command of
    `energy`, selected, and the step."""
    state, step = start()
    (cc,) = slots(state, UnitType.COMMAND_CENTER)
    units = state.units
    state = state.replace(units=units.replace(
        type=units.type.at[cc].set(UnitType.ORBITAL_COMMAND),
        energy=units.energy.at[cc].set(energy)))
    state, ts = select_cc(step, state)
    return state, step, ts, cc


@pytest.mark.slow  # 180 steps of CollectMineralsAndGas.
def test_a_mule_called_down_on_a_field_mines_it_and_dies_after_64_seconds():
    state, step, ts, cc = orbital(50.0)
    assert F.Effect_CalldownMULE_screen.id in available(ts)
    field_xy = LEFT_FIELDS[0]
    fields = slots(state, UnitType.MINERAL_FIELD)
    field = fields[np.argmin(np.linalg.norm(np.asarray(state.units.pos)[fields] - field_xy,
                                            axis=1))]
    state, ts = act(step, state, F.Effect_CalldownMULE_screen("now", pixel(state, field_xy)))
    assert result(ts) == 0
    (mule,) = slots(state, UnitType.MULE)
    units = state.units
    # Beside the field, towards the caster, gathering from it; 50 energy spent (of 50
    # and the selecting and calling steps' 16 loops of regeneration).
    gap = np.linalg.norm(np.asarray(units.pos[mule] - units.pos[field])) - 1.125 - 0.375
    assert abs(gap) < 0.2
    assert np.linalg.norm(np.asarray(units.pos[mule]) - COMMAND_CENTER) < np.linalg.norm(
        np.asarray(units.pos[field]) - COMMAND_CENTER)
    assert int(units.orders[mule, 0]) in (Order.GATHER, Order.RETURN)
    assert int(units.order_unit[mule, 0]) == field or int(units.home[mule]) == field
    np.testing.assert_allclose(float(units.energy[cc]), 16 * 0.5625 / 16, rtol=1e-5)
    assert float(units.life[mule]) == calldown.LIFE_LOOPS - 8
    # No supply. It mines its field alone (the SCVs are idle), 25 a trip, 171.6 loops a
    # time; its 1,434 loops end in the 179th step after the calldown's: 7 trips.
    assert ts.observation["player"][4] == 15
    before, bank = float(units.contents[field]), int(state.minerals)
    state, _ = wait(step, state, 179 - 1)
    assert bool(state.units.alive[mule])
    state, _ = wait(step, state, 1)
    assert not bool(state.units.alive[mule]) and not slots(state, UnitType.MULE).size
    assert before - float(state.units.contents[field]) == 7 * 25.0
    assert int(state.minerals) - bank == 7 * 25


@pytest.mark.slow  # 6 s of a melee game's compile.
def test_a_mule_needs_50_energy_and_lands_idle_off_a_field():
    state, step, ts, cc = orbital(49.0)
    target = (33.0, 21.0)
    _, ts = act(step, state, F.Effect_CalldownMULE_screen("now", pixel(state, target)))
    assert result(ts) == ActionResult.NotEnoughEnergy
    state = state.replace(units=state.units.replace(
        energy=state.units.energy.at[cc].set(jnp.float32(60.0))))
    state, ts = act(step, state, F.Effect_CalldownMULE_screen("now", pixel(state, target)))
    assert result(ts) == 0
    (mule,) = slots(state, UnitType.MULE)
    assert int(state.units.orders[mule, 0]) == Order.NONE
    assert np.linalg.norm(np.asarray(state.units.pos[mule]) - target) < 0.5
