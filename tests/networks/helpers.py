"""Shared test inputs built from the specs, and networks compiled once per session.

Everything is tiny (16x16, a few layers, batch 2) so the suite stays fast on 2 cores.
`network(name)` and `jitted_apply(name)` are cached, so each network is initialised and
compiled once for all the tests (networks and losses) that use it.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment import ObservationFormat, observation_spec
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.environment.interface.functions import FUNCTION_ARGS_MASK, NUM_FUNCTIONS
from sc2jax.networks import NetworkSpec, make_network

FMT = ObservationFormat(
    screen_size=16, minimap_size=16,
    screen_features=("player_relative", "unit_type", "unit_hit_points"),
    minimap_features=("player_relative", "camera"))
SPEC = NetworkSpec.from_format(FMT)
NAMES = ("atari", "fullyconv", "fullyconv_lstm", "arfullyconv")
BATCH = 2
OBS_KEYS = ("feature_screen", "feature_minimap", "player", "available_actions_mask")


def random_obs(seed: int, batch_shape: tuple[int, ...] = (BATCH,),
               fmt: ObservationFormat = FMT) -> dict[str, jnp.ndarray]:
    """Padded observations with random values within the spec's bounds.

    Feature layers lie in [0, scale); player statistics in [0, 1000); each function id
    is available with probability 1/2, no_op always.
    """
    rng = np.random.default_rng(seed)
    spec = observation_spec(fmt, padded=True)
    out = {}
    for key, layers in (("feature_screen", fmt.screen_layers),
                        ("feature_minimap", fmt.minimap_layers)):
        c, h, w = spec[key].shape
        scales = np.array([f.scale for f in layers]).reshape(c, 1, 1)
        out[key] = (rng.random(batch_shape + (c, h, w)) * scales).astype(np.int32)
    out["player"] = rng.integers(0, 1000, batch_shape + spec["player"].shape, dtype=np.int32)
    available = rng.random(batch_shape + (NUM_FUNCTIONS,)) < 0.5
    available[..., 0] = True
    out["available_actions_mask"] = available
    return {k: jnp.asarray(v) for k, v in out.items()}


def random_action(seed: int, available: np.ndarray, spec: NetworkSpec = SPEC) -> DenseAction:
    """A random available action within the action spec's bounds (unused arguments 0)."""
    rng = np.random.default_rng(seed)
    available = np.asarray(available)
    batch_shape = available.shape[:-1]
    flat = available.reshape(-1, available.shape[-1])
    function = np.array([rng.choice(np.flatnonzero(row)) for row in flat]).reshape(batch_shape)
    used = FUNCTION_ARGS_MASK[function]
    args = []
    for i, sizes in enumerate(spec.argument_sizes):
        shape = batch_shape + ((2,) if len(sizes) == 2 else ())
        value = (rng.random(shape) * np.array(sizes)).astype(np.int32)
        mask = used[..., i][..., None] if len(sizes) == 2 else used[..., i]
        args.append(np.where(mask, value, 0).astype(np.int32))
    return DenseAction(jnp.asarray(function, jnp.int32), *map(jnp.asarray, args))


def seq_obs(seed: int, t: int) -> dict[str, jnp.ndarray]:
    """Observations with leading dims [T, B]."""
    return random_obs(seed, (t, BATCH))


def fast_init(net, *args, seed: int = 0):
    """Parameters of `net.init(key, *args)`'s shapes, drawn with numpy.

    XLA compiles the random initialisers of a whole network slowly on CPU (tens of
    seconds on 2 busy cores), so tests take the shapes from `jax.eval_shape` and draw
    values on the host: N(0, 1/fan_in) for kernels and embeddings, 0 for biases.
    """
    rng = np.random.default_rng(seed)
    shapes = jax.eval_shape(net.init, jax.random.key(0), *args)

    def draw(path, leaf):
        name = jax.tree_util.keystr(path)
        if "bias" in name:
            return jnp.zeros(leaf.shape, leaf.dtype)
        fan_in = leaf.shape[-1] if "embedding" in name else int(np.prod(leaf.shape[:-1]))
        return jnp.asarray(rng.normal(0, 1 / np.sqrt(fan_in), leaf.shape), leaf.dtype)

    return jax.tree_util.tree_map_with_path(draw, shapes)


@functools.cache
def network(name: str):
    """(module, params) for a network at 16x16, initialised once."""
    net = make_network(name, FMT)
    obs = random_obs(0)
    if name == "fullyconv_lstm":
        params = fast_init(net, net.initial_carry(BATCH), jax.tree.map(lambda x: x[None], obs),
                           jnp.zeros((1, BATCH), bool))
    else:
        params = fast_init(net, obs)
    return net, params


@functools.cache
def jitted_apply(name: str):
    """The network's jitted `apply` (one compilation per input shape)."""
    return jax.jit(network(name)[0].apply)
