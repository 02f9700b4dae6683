"""The full game's speed on the CPU or an accelerator (docs/benchmarks.md, "The full
game"): agent steps per second of a melee map against the built-in AI, batched, and how
a step's cost grows with the units alive.

    python scripts/melee_speed.py --map=Acropolis --batches=1,8,32 --army=0,50,100,188

Every layer of the screen and minimap at 64² (PySC2's default format), `step_mul` 8, the
VeryEasy computer, random agent actions (the paper's random policy). For each batch
size, in one process: the XLA compilation of the vmapped, jitted step, then 5 untimed
steps and agent steps per second over 20. For the unit counts, one batch of
environments whose both players have `army` idle Marines beside their Command Center
(each side's supply: 12 SCVs + `army`), timed the same way, on the leading unit slots
in use (the default) and on every slot. With `--paired_resources`, each batch size is
timed again with the resources in the pair work (`MiniGame.resource_slots` None: combat,
collisions and harvesting over every pair of slots), the engine before c68a2fd.
"""

from __future__ import annotations

import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np
from absl import app, flags

from sc2jax.environment.agents.random_agent import random_action
from sc2jax.environment.engine.rules.state import Owner, place, slots_in_use
from sc2jax.environment.engine.rules.units import UnitType
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.players import Difficulty
from sc2jax.environment.interface.specs import ObservationFormat

FLAGS = flags.FLAGS
flags.DEFINE_string("map", "Acropolis", "A ladder map.")
flags.DEFINE_list("batches", ["1", "8", "32"], "Batch sizes (environments stepped together).")
flags.DEFINE_list("army", ["0", "50", "100", "188"],
                  "Marines a side for the unit-count rows ('' to skip them).")
flags.DEFINE_integer("army_batch", 8, "Environments of the unit-count rows.")
flags.DEFINE_integer("steps", 20, "Timed steps per row.")
flags.DEFINE_bool("paired_resources", False,
                  "Also time each batch size with the resources in the pair work.")


def _simulator(use_slot_sizes: bool = True, paired_resources: bool = False) -> Simulator:
    sim = Simulator(FLAGS.map, ObservationFormat(), step_mul=8, score_index=-1,
                    computer=Difficulty.very_easy, use_slot_sizes=use_slot_sizes)
    if paired_resources:  # The same game with its resources in every pair.
        object.__setattr__(sim, "game", dataclasses.replace(sim.game, resource_slots=None))
    return sim


def _with_army(sim: Simulator, state, count: int):
    """Both players get `count` idle Marines in rows beside their Command Center."""
    units = state.units
    first = int(slots_in_use(units.alive))
    homes = np.asarray(sim.game.start_cameras(state.map_state))
    offsets = np.stack(np.meshgrid(np.arange(-9.0, 10.0), np.arange(6.0, 16.0)), -1)
    offsets = offsets.reshape(-1, 2)[:count]
    next_tag = state.next_tag
    for side, owner in enumerate((Owner.SELF, Owner.ENEMY)):
        away = np.sign(np.float32(sim.game.geometry.size) / 2 - homes[side])
        slots = first + side * count + np.arange(count)
        units, next_tag = place(units, slots, UnitType.MARINE, owner,
                                jnp.asarray(homes[side] + offsets * away, jnp.float32), next_tag)
    return state.replace(units=units, next_tag=next_tag)


def _measure(sim: Simulator, batch: int, army: int = 0) -> tuple[float, float, int]:
    """(compile seconds, agent steps per second, units alive at the start)."""
    def step(state, timestep, key):
        action = random_action(key, timestep.observation["available_actions_mask"],
                               sim.fmt.types)
        return sim.step(state, action)

    keys = jax.random.split(jax.random.PRNGKey(0), batch)
    state, timestep = jax.jit(jax.vmap(sim.reset))(keys)
    if army:
        one = jax.tree.map(lambda x: x[0], state)
        one = _with_army(sim, one, army)
        state = jax.tree.map(lambda x: jnp.broadcast_to(x, (batch, *x.shape)), one)
        # The reset's observation stays the first one acted on: its available actions.
    alive = int(jnp.sum(state.units.alive[0]))
    start = time.perf_counter()
    compiled = jax.jit(jax.vmap(step)).lower(state, timestep, keys).compile()
    seconds = time.perf_counter() - start
    for i in range(5):
        state, timestep = compiled(state, timestep, jax.random.split(jax.random.PRNGKey(i), batch))
    jax.block_until_ready(timestep)
    start = time.perf_counter()
    for i in range(FLAGS.steps):
        state, timestep = compiled(state, timestep,
                                   jax.random.split(jax.random.PRNGKey(100 + i), batch))
    jax.block_until_ready(timestep)
    return seconds, FLAGS.steps * batch / (time.perf_counter() - start), alive


def main(argv):
    del argv
    print(f"{FLAGS.map}, every layer at 64², step_mul 8, the VeryEasy computer, random "
          f"actions on {jax.devices()[0].platform}")
    paired = " agent steps/s, resources paired |" if FLAGS.paired_resources else ""
    print(f"| environments | compile (s) | agent steps/s | game loops/s |{paired}\n"
          f"|---:|---:|---:|---:|{'---:|' if paired else ''}")
    sim = _simulator()
    for batch in [int(b) for b in FLAGS.batches]:
        seconds, rate, _ = _measure(sim, batch)
        row = f"| {batch} | {seconds:.0f} | {rate:,.0f} | {8 * rate:,.0f} |"
        if FLAGS.paired_resources:
            row += f" {_measure(_simulator(paired_resources=True), batch)[1]:,.0f} |"
        print(row, flush=True)
    armies = [int(a) for a in FLAGS.army if a]
    if not armies:
        return
    print(f"\n| Marines a side | units alive | steps/s, leading slots | steps/s, all "
          f"{sim.game.num_slots} slots |\n|---:|---:|---:|---:|")
    every = _simulator(use_slot_sizes=False)
    for army in armies:
        _, leading, alive = _measure(sim, FLAGS.army_batch, army)
        _, full, _ = _measure(every, FLAGS.army_batch, army)
        print(f"| {army} | {alive} | {leading:,.0f} | {full:,.0f} |", flush=True)


if __name__ == "__main__":
    app.run(main)
