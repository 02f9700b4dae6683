"""The contract's jit/vmap half: a batched step equals the single steps it batches (in a
file of its own, so that the two test workers share the contract's work; the simple maps'
single steps are the contract's programs, DefeatZerglingsAndBanelings' here are its own)."""


import jax
import numpy as np
import pytest

from sc2jax.environment import FUNCTIONS, MAPS, to_dense
from tests.environment.helpers import PARAMS, compiled, small_sim

MAP_NAMES = sorted(MAPS)


# The simple engine's maps and one wave map, run on all its slots (`small_sim`'s
# `use_slot_sizes=False`): its batched step on its slot sizes compiles every size, single
# and batched (75 s in a 2-core suite; on all slots, 30 s). The slot sizes
# are checked apart: tests/environment/test_combat.py plays the wave maps on their leading
# slots as on all slots, and tests/environment/test_lazy.py checks `smallest_fit`'s
# batching rule (the batch's largest need, nested vmaps too). DefeatZerglingsAndBanelings
# covers DefeatRoaches' paths and more (the banelings' bursts). The economy maps are left
# out (CollectMineralsAndGas's batched step took 107 s): beyond JAX's own batching rules,
# theirs rests on the same `smallest_fit`.
# MoveToBeacon in the fast tier; the other maps in the slow one.
@pytest.mark.parametrize("map_name", [
    m if m == "MoveToBeacon" else pytest.param(m, marks=pytest.mark.slow) for m in MAP_NAMES
    if m not in ("BuildMarines", "CollectMineralsAndGas", "DefeatRoaches")])
def test_vmap_matches_single(map_name):
    sim = small_sim(map_name)
    reset, step = compiled(sim)
    vreset, vstep = compiled(sim, batched=True)
    # Four environments, as tests/environment/engine/xla/test_devices.py batches MoveToBeacon (one
    # program for both files).
    keys = jax.random.split(jax.random.PRNGKey(5), 4)
    states, tss = vreset(keys, PARAMS)
    actions = to_dense([FUNCTIONS.select_army("select"), FUNCTIONS.no_op(),
                        FUNCTIONS.move_camera((3, 4)), FUNCTIONS.select_army("add")])
    _, tss2 = vstep(states, actions, PARAMS)
    for i in range(4):
        state, ts = reset(keys[i], PARAMS)
        assert np.array_equal(ts.observation["feature_screen"],
                              tss.observation["feature_screen"][i])
        action = jax.tree_util.tree_map(lambda x, i=i: x[i], actions)
        _, ts = step(state, action, PARAMS)
        for key in ts.observation:
            assert np.array_equal(ts.observation[key], tss2.observation[key][i]), key
        assert float(ts.reward) == float(tss2.reward[i])
        assert int(ts.step_type) == int(tss2.step_type[i])
