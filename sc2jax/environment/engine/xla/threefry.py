"""`split`, `bits` and `randint`: the simulator's key splits, the game loop's jitter
draws and the random agent's draws, as `jax.random` makes them, each one fused
computation.

JAX lowers its Threefry-2x32 hash on CPU as a loop of five rounds (`fori_loop`), which
XLA runs as a while loop of small kernels dispatched one after another: every game loop
split its key and drew the weapons' cooldown jitter through such loops (about 240
kernels per agent step of FindAndDefeatZerglings at 64 environments). Written out as
its twenty rounds, the hash is elementwise arithmetic that XLA fuses with what uses it.

They give exactly `jax.random.split(key, num)`, `jax.random.bits(key, shape)` and
`jax.random.randint(key, shape, minval, maxval)` (int32) for a raw `uint32[2]` key with
JAX's default `jax_threefry_partitionable` (checked by tests/environment/test_threefry.py),
so the game's draws, and its episodes, are those of `jax.random`. Keys are raw
`uint32[2]` arrays (`jax.random.PRNGKey`).
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

# The hash's rotations, four rounds at a time, alternating (Salmon et al. 2011, Threefry-2x32).
_ROTATIONS = ((13, 15, 26, 6), (17, 29, 16, 24))
_PARITY = np.uint32(0x1BD11BDA)


def _rotate_left(x, bits: int):
    return (x << np.uint32(bits)) | (x >> np.uint32(32 - bits))


def hash2x32(key, x0, x1):
    """Threefry-2x32 with 20 rounds: the pair of counters (x0, x1) hashed under `key`.

    Args:
      key: uint32[2].
      x0, x1: uint32 arrays of one shape.

    Returns:
      (y0, y1), uint32 arrays of that shape.
    """
    k = [key[0], key[1], key[0] ^ key[1] ^ _PARITY]
    x0, x1 = x0 + k[0], x1 + k[1]
    for block in range(5):
        for rotation in _ROTATIONS[block % 2]:
            x0 = x0 + x1
            x1 = _rotate_left(x1, rotation) ^ x0
        x0 = x0 + k[(block + 1) % 3]
        x1 = x1 + k[(block + 2) % 3] + np.uint32(block + 1)
    return x0, x1


def _counters(size: int):
    """The flat indices 0..size-1 as 64-bit counters: (high words, low words)."""
    if size >= 2 ** 32:
        raise ValueError(f"{size} draws exceed the 2**32 counters this module supports")
    return jnp.zeros(size, jnp.uint32), jnp.arange(size, dtype=jnp.uint32)


def split(key, num: int = 2):
    """uint32[num, 2]: `num` new keys, `jax.random.split(key, num)`."""
    y0, y1 = hash2x32(key, *_counters(num))
    return jnp.stack([y0, y1], axis=1)


def bits(key, shape: tuple[int, ...]):
    """uint32[shape]: uniform random words, `jax.random.bits(key, shape, jnp.uint32)`."""
    y0, y1 = hash2x32(key, *_counters(math.prod(shape)))
    return (y0 ^ y1).reshape(shape)


def randint(key, shape: tuple[int, ...], minval, maxval):
    """int32[shape]: `jax.random.randint(key, shape, minval, maxval)` (int32 bounds,
    broadcast to `shape`): two words per value, reduced modulo the span as JAX does (a
    span of 0 or less gives minval)."""
    high_key, low_key = split(key)
    minval = jnp.broadcast_to(jnp.asarray(minval, jnp.int32), shape)
    maxval = jnp.broadcast_to(jnp.asarray(maxval, jnp.int32), shape)
    span = jnp.where(maxval <= minval, np.uint32(1), (maxval - minval).astype(jnp.uint32))
    # 2**32 mod span, as (2**16 mod span)**2 mod span, and (a * b) mod n as
    # ((a mod n) * (b mod n)) mod n, in uint32 arithmetic.
    multiplier = np.uint32(2 ** 16) % span
    multiplier = (multiplier * multiplier) % span
    offset = (bits(high_key, shape) % span) * multiplier + bits(low_key, shape) % span
    return minval + (offset % span).astype(jnp.int32)
