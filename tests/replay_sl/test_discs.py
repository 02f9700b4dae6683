"""The pixels a unit's disc covers in a replay's layers (`observations._disc_pixels`)
against the definition: the pixels whose centres lie within the disc, and always the
pixel holding its centre, on the layer, in the units' order."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sc2jax.replay_sl.observations import _disc_pixels

SIZE = 9


def _by_definition(pixels, r):
    pairs = []
    for n, (px, py) in enumerate(pixels):
        for y in range(SIZE):
            for x in range(SIZE):
                holds = x == np.floor(px) and y == np.floor(py)
                if holds or (x + 0.5 - px) ** 2 + (y + 0.5 - py) ** 2 <= r * r:
                    pairs.append((n, y * SIZE + x))
    return pairs


@pytest.mark.parametrize("r", [0.5, 0.75, 4 / 3, 2.6])
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 31 - 1))
def test_a_disc_covers_its_definitions_pixels_in_unit_order(r, seed):
    rng = np.random.default_rng(seed)
    pixels = rng.uniform(-2, SIZE + 2, (12, 2)).astype(np.float32)
    pixels[:4] = np.round(pixels[:4] * 2) / 2  # On pixel edges and centres.
    disc, pixel = _disc_pixels(pixels, r, SIZE)
    assert np.all(np.diff(disc) >= 0)
    assert sorted(zip(disc.tolist(), pixel.tolist())) == _by_definition(pixels, r)
