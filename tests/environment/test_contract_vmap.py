"""The contract's jit/vmap half: a batched step equals the single steps it batches (in a
file of its own, so that test workers share the contract's compilation work)."""

import jax
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS, MAPS, to_dense

from .conftest import PARAMS, compiled, small_sim

MAP_NAMES = sorted(MAPS)


# One map of each engine: the economy maps' and the wave maps' batched steps compile all
# their slot sizes (CollectMineralsAndGas and DefeatZerglingsAndBanelings took 107 and
# 112 s of a 2-core suite). DefeatZerglingsAndBanelings covers DefeatRoaches' paths and
# more (the banelings' bursts). The economy maps are left out: beyond JAX's own batching
# rules, their batched step relies on `lazy.smallest_fit`'s (the batch's largest need),
# which the wave map here and tests/environment/test_lazy.py (nested vmaps too) check.
@pytest.mark.parametrize("map_name", [m for m in MAP_NAMES if m not in (
    "BuildMarines", "CollectMineralsAndGas", "DefeatRoaches")])
def test_vmap_matches_single(map_name):
    sim = small_sim(map_name)
    reset, step = compiled(sim)
    vreset, vstep = compiled(sim, batched=True)
    keys = jax.random.split(jax.random.PRNGKey(5), 3)
    states, tss = vreset(keys, PARAMS)
    actions = to_dense([FUNCTIONS.select_army("select"), FUNCTIONS.no_op(),
                        FUNCTIONS.move_camera((3, 4))])
    _, tss2 = vstep(states, actions, PARAMS)
    for i in range(3):
        state, ts = reset(keys[i], PARAMS)
        assert np.array_equal(ts.observation["feature_screen"],
                              tss.observation["feature_screen"][i])
        action = jax.tree_util.tree_map(lambda x, i=i: x[i], actions)
        _, ts = step(state, action, PARAMS)
        for key in ts.observation:
            assert np.array_equal(ts.observation[key], tss2.observation[key][i]), key
        assert float(ts.reward) == float(tss2.reward[i])
        assert int(ts.step_type) == int(tss2.step_type[i])
