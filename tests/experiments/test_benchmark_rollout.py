"""The simulator benchmark's rollout at one environment runs the step unbatched (as a
single environment does), with the same results as a `vmap` of one (run in a process of
its own: the benchmark module defines absl flags)."""

import subprocess
import sys
import textwrap

CHECK = textwrap.dedent("""
    import jax, jax.numpy as jnp, numpy as np
    from unittest import mock
    from sc2jax.environment import ObservationFormat, Simulator
    from sc2jax.experiments import benchmark

    def vmapped(fn, num_envs, in_axes=0, out_axes=0):
        return jax.vmap(fn, in_axes=in_axes, out_axes=out_axes)

    # per_env: a switch, an argument without the environment axis, out_axes=1.
    def fn(x, k):
        return jnp.stack([jax.lax.switch(x[0] % 3, [lambda: k, lambda: -k, lambda: 2 * k]),
                          x[1] * k])
    x, k = jnp.array([[5, 7]]), jnp.float32(1.5)
    one = benchmark.per_env(fn, 1, in_axes=(0, None), out_axes=1)(x, k)
    assert one.shape == (2, 1), one.shape
    np.testing.assert_array_equal(one, vmapped(fn, 1, (0, None), 1)(x, k))
    # Unbatched, the switch is a cond that runs one branch; vmapped, all and a select.
    assert "cond" in str(jax.make_jaxpr(benchmark.per_env(fn, 1, (0, None)))(x, k))
    assert "cond" not in str(jax.make_jaxpr(vmapped(fn, 1, (0, None)))(x, k))

    # The whole rollout: every leaf of the carry the same, bit for bit, after 12 steps.
    sim = Simulator(map_name="FindAndDefeatZerglings",
                    fmt=ObservationFormat(screen_size=16, minimap_size=16))
    rollout, carry = benchmark.sc2jax_rollout(sim, 1, 12)
    with mock.patch.object(benchmark, "per_env", vmapped):
        plain, plain_carry = benchmark.sc2jax_rollout(sim, 1, 12)
    a, b = rollout(carry), plain(plain_carry)
    for u, v in zip(jax.tree.leaves(a), jax.tree.leaves(b)):
        assert u.shape == v.shape and u.dtype == v.dtype, (u.shape, v.shape)
        np.testing.assert_array_equal(u, v)
    print("same")
""")


def test_one_environment_runs_unbatched_with_the_same_results():
    out = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().endswith("same")
