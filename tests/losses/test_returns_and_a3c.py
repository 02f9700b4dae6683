"""n-step returns and the A3C / V-trace losses on hand-worked numbers."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sc2jax.losses import a3c_loss, n_step_returns, truncated_returns, vtrace_loss

_A3C = jax.jit(a3c_loss)
_A3C_GRAD = jax.jit(jax.grad(lambda *a: a3c_loss(*a).loss, argnums=(0, 1, 5, 6)))


def test_truncated_returns_hand_worked():
    # G_2 = 3 + 0.9 * 10 = 12; G_1 = 2 + 0 * 12 = 2 (termination); G_0 = 1 + 0.9 * 2 = 2.8.
    g = truncated_returns(jnp.array([1.0, 2.0, 3.0]), jnp.array([0.9, 0.0, 0.9]), 10.0)
    np.testing.assert_allclose(g, [2.8, 2.0, 12.0], rtol=1e-6)


def _python_truncated(r, d, bootstrap):
    out, g = [], bootstrap
    for t in reversed(range(len(r))):
        g = r[t] + d[t] * g
        out.append(g)
    return out[::-1]


def _python_n_step(r, d, v, n):
    T = len(r)
    out = []
    for t in range(T):
        g, scale = 0.0, 1.0
        for k in range(n):
            if t + k >= T:
                break
            g += scale * r[t + k]
            scale *= d[t + k]
            last = t + k
        out.append(g + scale * v[last])
    return out


def test_returns_match_a_python_loop():
    rng = np.random.default_rng(0)
    r = rng.normal(size=40).astype(np.float32)  # K = 40 as in the paper
    d = np.where(rng.random(40) < 0.1, 0.0, 0.99).astype(np.float32)
    v = rng.normal(size=40).astype(np.float32)
    np.testing.assert_allclose(truncated_returns(r, d, 1.5), _python_truncated(r, d, 1.5),
                               rtol=1e-5)
    np.testing.assert_allclose(n_step_returns(r, d, v, 5), _python_n_step(r, d, v, 5),
                               rtol=1e-5, atol=1e-5)
    with pytest.raises(ValueError, match="n must be a positive int"):
        n_step_returns(r, d, v, 0)


def _inputs():
    # T = 2. v = [1, 2]; log π(a) = [ln 0.5, ln 0.25]; r = [1, 0]; discount 0.5; v(s_T) = 4.
    used = np.zeros((2, 13), bool)
    used[0, 0] = True  # step 0's function takes screen only; step 1's takes nothing
    return (jnp.array([1.0, 2.0]), jnp.log(jnp.array([0.5, 0.25])), jnp.array([1.0, 0.0]),
            jnp.array([0.5, 0.5]), jnp.float32(4.0), jnp.array([1.0, 1.0]),
            jnp.full((2, 13), 2.0), jnp.asarray(used))


def test_a3c_loss_hand_worked():
    out = _A3C(*_inputs())
    # G_1 = 0 + 0.5 * 4 = 2; G_0 = 1 + 0.5 * 2 = 2. Advantages: [2 - 1, 2 - 2] = [1, 0].
    np.testing.assert_allclose(out.value_target, [2.0, 2.0])
    np.testing.assert_allclose(out.advantage, [1.0, 0.0])
    # policy: -mean([1 * ln 0.5, 0 * ln 0.25]) = ln 2 / 2.
    np.testing.assert_allclose(out.policy_loss, np.log(2) / 2, rtol=1e-6)
    # value: mean(0.5 * [1², 0²]) = 0.25.
    np.testing.assert_allclose(out.value_loss, 0.25)
    # entropy: H = [1 + 2 (screen used), 1 + 0] -> -1e-3 * mean([3, 1]) = -2e-3.
    np.testing.assert_allclose(out.entropy_loss, -2e-3, rtol=1e-6)
    np.testing.assert_allclose(out.loss, np.log(2) / 2 + 0.5 * 0.25 - 2e-3, rtol=1e-6)


def test_a3c_gradients():
    g_v, g_logpi, g_hfn, g_harg = _A3C_GRAD(*_inputs())
    # d/dv_t of β mean(½ (G - v)²) = β (v - G) / T = 0.5 * [-1, 0] / 2; the advantage is
    # stop-gradiented, so the policy term adds nothing to the value's gradient.
    np.testing.assert_allclose(g_v, [-0.25, 0.0])
    # d/dlog π_t = -A_t / T.
    np.testing.assert_allclose(g_logpi, [-0.5, 0.0])
    np.testing.assert_allclose(g_hfn, [-5e-4, -5e-4])
    # Entropy of arguments the function does not use gets no gradient.
    expected = np.zeros((2, 13))
    expected[0, 0] = -5e-4
    np.testing.assert_allclose(g_harg, expected)


def test_jit_and_no_jit_agree():
    eager, jitted = a3c_loss(*_inputs()), _A3C(*_inputs())
    for a, b in zip(eager, jitted):
        np.testing.assert_allclose(a, b, rtol=1e-6)


def test_vtrace_on_policy_equals_n_step_returns():
    # With μ = π (ρ = 1) and λ = 1, the V-trace targets are the truncated n-step returns.
    v, log_pi, r, d, boot, hf, ha, used = _inputs()
    out = jax.jit(vtrace_loss)(v, log_pi, log_pi, r, d, boot, hf, ha, used)
    np.testing.assert_allclose(out.value_target, [2.0, 2.0], rtol=1e-6)
    # The PG advantage is r_t + d_t v_s(t+1) - v_t: [1 + 0.5 * 2 - 1, 0 + 0.5 * 4 - 2].
    np.testing.assert_allclose(out.advantage, [1.0, 0.0], rtol=1e-6)
    np.testing.assert_allclose(out.loss, _A3C(*_inputs()).loss, rtol=1e-6)


def test_shape_errors():
    v, log_pi, r, d, boot, hf, ha, used = _inputs()
    with pytest.raises(AssertionError):
        a3c_loss(v, log_pi, r[:1], d, boot, hf, ha, used)
