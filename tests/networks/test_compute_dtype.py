"""Every network computes in bfloat16 on request: float32 parameters, outputs and
gradients, and the float32 network's outputs to bfloat16's precision."""

import jax
import jax.numpy as jnp
import pytest

from sc2jax.networks import make_network
from tests.networks.helpers import BATCH, FMT, network, random_obs


@pytest.mark.slow
@pytest.mark.parametrize("name", ["atari", "fullyconv", "fullyconv_lstm", "arfullyconv"])
def test_bfloat16_keeps_float32_outputs_close_to_float32(name):
    net32, params = network(name)
    net16 = make_network(name, FMT, dtype="bfloat16")
    obs = random_obs(0)
    if name == "fullyconv_lstm":
        args = (net32.initial_carry(BATCH), jax.tree.map(lambda x: x[None], obs),
                jnp.zeros((1, BATCH), bool))
        apply = lambda net, p: net.apply(p, *args)[1]  # noqa: E731
    else:
        apply = lambda net, p: net.apply(p, obs)  # noqa: E731
    out32, out16 = apply(net32, params), apply(net16, params)
    leaves32, leaves16 = jax.tree.leaves(out32), jax.tree.leaves(out16)
    assert all(x.dtype == jnp.float32 for x in leaves16) and len(leaves16) == len(leaves32)
    for a, b in zip(leaves32, leaves16):
        scale = float(jnp.max(jnp.abs(a))) + 1e-3
        # bfloat16 keeps 8 bits of mantissa: about 0.4% of each value, summed over layers.
        assert float(jnp.max(jnp.abs(a - b))) < 0.05 * scale
    grads = jax.grad(lambda p: jnp.sum(apply(net16, p).value))(params)
    assert all(g.dtype == jnp.float32 and bool(jnp.isfinite(g).all())
               for g in jax.tree.leaves(grads))
    assert any(float(jnp.abs(g).max()) > 0 for g in jax.tree.leaves(grads))


def test_an_unknown_dtype_is_refused():
    with pytest.raises(ValueError, match=r"unknown compute dtype 'float16'; allowed: "
                                         r"\['float32', 'bfloat16'\]"):
        make_network("fullyconv", FMT, dtype="float16")
