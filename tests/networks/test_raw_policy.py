"""The raw policy distribution: hand-worked numbers, the rows a raw action may name,
unused arguments, and agreement between sampling and the log-probability."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.environment.interface.functions import RAW_FUNCTIONS
from sc2jax.environment.interface.raw import RawAction
from sc2jax.networks import policy, raw_policy
from sc2jax.networks.outputs import PixelLogits
from sc2jax.networks.raw_policy import RAW_ARGS_MASK, RawNetworkOutput

GRID = (4, 3)  # A 4x3 raw grid.
ROWS = 5
ATTACK_PT = RAW_FUNCTIONS.Attack_pt.id  # (queued, unit_tags, world)
ATTACK_UNIT = RAW_FUNCTIONS.Attack_unit.id  # (queued, unit_tags, target_unit_tag)
TRAIN_SCV = RAW_FUNCTIONS.Train_SCV_quick.id  # (queued, unit_tags)


def _output(units=(0.0, 1.0, -1.0, 2.0, 0.0), own=(True, True, False, True, False),
            real=(True, True, True, True, False), function_logits=None):
    """A batch of one: uniform world, queued and target heads."""
    fl = jnp.zeros((1, len(RAW_FUNCTIONS))) if function_logits is None else function_logits
    return RawNetworkOutput(
        value=jnp.zeros((1,)), function_logits=fl,
        world=PixelLogits(jnp.zeros((1, GRID[0] * GRID[1])), width=GRID[0]),
        queued=jnp.zeros((1, 2)), units=jnp.asarray([units]),
        target=jnp.zeros((1, ROWS)), own=jnp.asarray([own]), real=jnp.asarray([real]))


def _available(*ids):
    return jnp.zeros((1, len(RAW_FUNCTIONS)), bool).at[0, list(ids)].set(True)


def _action(function, world=(0, 0), queued=0, units=(False,) * ROWS, target=-1):
    return RawAction(jnp.asarray([function]), jnp.asarray([world]), jnp.asarray([queued]),
                     jnp.asarray([units]), jnp.asarray([target]))


def _log_sigmoid(x):
    return -np.log1p(np.exp(-x))


def test_the_argument_table_is_pysc2s():
    fields = ("world", "queued", "unit_tags", "target_unit_tag")
    for f in (RAW_FUNCTIONS.no_op, RAW_FUNCTIONS.raw_move_camera, RAW_FUNCTIONS.Attack_pt,
              RAW_FUNCTIONS.Attack_unit, RAW_FUNCTIONS.Train_SCV_quick):
        assert {fields[i] for i in np.flatnonzero(RAW_ARGS_MASK[f.id])} == \
            {a.name for a in f.args}, f.name
    assert RAW_ARGS_MASK.shape == (len(RAW_FUNCTIONS), 4)


def test_log_prob_hand_worked():
    # Available {no_op, Attack_pt}; the logit of Attack_pt is ln 3: π = 3/4.
    out = _output(function_logits=jnp.zeros((1, len(RAW_FUNCTIONS))).at[0, ATTACK_PT].set(
        np.log(3.0)))
    units = (True, False, True, True, False)  # Row 2 is not own: it counts for nothing.
    lp = raw_policy.log_prob(out, _action(ATTACK_PT, (2, 1), 1, units),
                             _available(0, ATTACK_PT))
    rows = _log_sigmoid(0.0) + _log_sigmoid(-1.0) + _log_sigmoid(2.0)
    expected = np.log(0.75) + np.log(1 / 12) + np.log(0.5) + rows
    np.testing.assert_allclose(lp.total[0], expected, rtol=1e-5)
    np.testing.assert_allclose(lp.arguments[2][0], rows, rtol=1e-5)
    assert float(lp.arguments[3][0]) == 0.0  # Attack_pt takes no target.


def test_entropy_counts_own_rows_only():
    ent = raw_policy.entropy(_output(), _available(0, ATTACK_PT))
    p = 1 / (1 + np.exp(-np.array([0.0, 1.0, 2.0])))
    expected = -np.sum(p * np.log(p) + (1 - p) * np.log(1 - p))
    np.testing.assert_allclose(ent.arguments[2][0], expected, rtol=1e-5)
    np.testing.assert_allclose(ent.function[0], np.log(2), rtol=1e-5)
    np.testing.assert_allclose(ent.arguments[0][0], np.log(12), rtol=1e-5)
    np.testing.assert_allclose(ent.arguments[3][0], np.log(4), rtol=1e-5)  # 4 real rows.


def test_rows_the_player_cannot_command_get_no_gradient():
    out = _output()
    grad = jax.grad(lambda units: raw_policy.log_prob(
        out._replace(units=units), _action(ATTACK_PT, units=(True, False, True, True, False)),
        _available(0, ATTACK_PT)).total.sum())(out.units)
    g = np.asarray(grad[0])
    assert g[2] == 0.0 and g[4] == 0.0 and np.all(g[[0, 1, 3]] != 0.0)


def test_samples_name_own_rows_and_real_targets_and_zero_unused_arguments():
    out = jax.tree.map(lambda x: jnp.repeat(x, 4000, axis=0), _output())
    available = jnp.repeat(_available(0, ATTACK_PT, ATTACK_UNIT, TRAIN_SCV), 4000, axis=0)
    a = jax.jit(raw_policy.sample)(jax.random.PRNGKey(0), out, available)
    function, units, target = map(np.asarray, (a.function, a.units, a.target_unit))
    assert set(np.unique(function)) == {0, ATTACK_PT, ATTACK_UNIT, TRAIN_SCV}
    assert not units[:, [2, 4]].any()  # Never a row the player does not own.
    assert not units[function == 0].any() and (target[function != ATTACK_UNIT] == -1).all()
    assert set(np.unique(target[function == ATTACK_UNIT])) == {0, 1, 2, 3}
    assert (np.asarray(a.world)[function != ATTACK_PT] == 0).all()
    # Each own row is commanded with probability σ(logit).
    taking = units[function != 0]
    np.testing.assert_allclose(taking[:, [0, 1, 3]].mean(0), 1 / (1 + np.exp(-np.array(
        [0.0, 1.0, 2.0]))), atol=0.03)
    # The sampled actions' log-probabilities average to minus the entropy.
    lp = raw_policy.log_prob(out, a, available)
    ent = raw_policy.entropy(out, available)
    used = raw_policy.used_arguments(a.function)
    entropy = ent.function + jnp.sum(jnp.where(used, jnp.stack(ent.arguments, -1), 0), -1)
    np.testing.assert_allclose(-lp.total.mean(), entropy.mean(), rtol=0.03)


def test_the_mode_takes_the_likeliest_rows():
    out = _output(function_logits=jnp.zeros((1, len(RAW_FUNCTIONS))).at[0, TRAIN_SCV].set(5))
    a = raw_policy.sample(None, out, _available(0, TRAIN_SCV))
    assert int(a.function[0]) == TRAIN_SCV
    np.testing.assert_array_equal(a.units[0], [False, True, False, True, False])
    assert int(a.target_unit[0]) == -1


def test_policy_of_chooses_by_the_output():
    assert raw_policy.policy_of(_output()) is raw_policy
    with pytest.raises(TypeError, match="RawAction"):
        raw_policy.log_prob(_output(), object(), _available(0))
    assert raw_policy.policy_of(object()) is policy
