"""Plays melee games of players against the simulator's built-in AI and prints the table
of wins, ties and losses (docs/full_game.md, "The built-in AI").

    python scripts/computer_games.py --map=Acropolis --games=4 \
        --players=idle,random,rush,very_easy,easy,medium,hard \
        --opponents=very_easy,easy,medium,hard

Every pairing's games run in one jitted loop, vmapped (`agents.melee_matches`).
"""

from __future__ import annotations

import itertools
import json
import time

import jax
import jax.numpy as jnp
import numpy as np
from absl import app, flags

from sc2jax.environment.agents import melee_matches
from sc2jax.environment.engine import computer
from sc2jax.environment.engine.rules.state import Outcome
from sc2jax.environment.engine.simulator import Simulator
from sc2jax.environment.interface.players import Difficulty
from sc2jax.environment.interface.specs import ObservationFormat

FLAGS = flags.FLAGS
flags.DEFINE_string("map", "Acropolis", "A ladder map.")
flags.DEFINE_integer("games", 4, "Games per pairing.")
flags.DEFINE_list("players", ["idle", "random", "rush", "very_easy", "easy", "medium", "hard"],
                  "The players: idle, random, rush, or a difficulty.")
flags.DEFINE_list("opponents", ["very_easy", "easy", "medium", "hard"],
                  "The computer's difficulties.")
flags.DEFINE_integer("num_slots", 384, "Unit slots (Simulator.num_slots): room for Hard's 38 "
                     "SCVs and army beside the 160 resources.")
flags.DEFINE_integer("step_mul", 16, "Game loops per agent step.")
flags.DEFINE_integer("max_loops", 28_800, "Game loops before a tie (PySC2's 30 minutes).")
flags.DEFINE_integer("seed", 0, "The first game's seed.")
flags.DEFINE_string("json", None, "Write the table here as JSON too.")

PLAYERS = {"idle": (melee_matches.IDLE, melee_matches.RUSH),
           "random": (melee_matches.RANDOM, melee_matches.RUSH),
           "rush": (melee_matches.SCRIPTED, melee_matches.RUSH)}


def _player(name: str):
    if name in PLAYERS:
        return PLAYERS[name]
    if name in Difficulty.__members__:
        return melee_matches.SCRIPTED, computer.level(Difficulty[name])
    raise ValueError(f"unknown player {name!r}; expected one of "
                     f"{sorted(PLAYERS)} or a difficulty of {list(Difficulty.__members__)}")


def main(argv):
    del argv
    players = [(name, *_player(name)) for name in FLAGS.players]
    opponents = [(name, computer.level(Difficulty[name])) for name in FLAGS.opponents]
    fmt = ObservationFormat(screen_size=16, minimap_size=16)
    sim = Simulator(FLAGS.map, fmt, step_mul=FLAGS.step_mul, score_index=-1,
                    use_slot_sizes=False, num_slots=FLAGS.num_slots)
    pairs = list(itertools.product(players, opponents))
    rows = [(kind, mine, theirs) for (_, kind, mine), (_, theirs) in pairs
            for _ in range(FLAGS.games)]
    stack = lambda levels: jax.tree.map(lambda *v: jnp.stack(v), *[  # noqa: E731
        melee_matches.as_arrays(level) for level in levels])
    kinds = jnp.asarray([r[0] for r in rows], jnp.int32)
    mine, theirs = stack([r[1] for r in rows]), stack([r[2] for r in rows])
    keys = jax.random.split(jax.random.PRNGKey(FLAGS.seed), len(rows))
    max_steps = -(-FLAGS.max_loops // FLAGS.step_mul)
    def outcome(k, kind, m, t):
        state, _ = melee_matches.play(sim, k, kind, m, t, max_steps)
        return state.outcome, state.game_loop

    start = time.time()
    outcomes, loops = jax.device_get(jax.jit(jax.vmap(outcome))(keys, kinds, mine, theirs))
    seconds = time.time() - start
    table = []
    for index, ((player, _, _), (opponent, _)) in enumerate(pairs):
        games = slice(index * FLAGS.games, (index + 1) * FLAGS.games)
        got = outcomes[games]
        table.append(dict(player=player, computer=opponent,
                          wins=int(np.sum(got == Outcome.VICTORY)),
                          ties=int(np.sum((got == Outcome.TIE) | (got == Outcome.RUNNING))),
                          losses=int(np.sum(got == Outcome.DEFEAT)),
                          mean_minutes=float(np.mean(loops[games]) / 22.4 / 60)))
    print(f"{len(rows)} games on {FLAGS.map} ({FLAGS.num_slots} slots) in {seconds:.0f} s "
          "(compile included)")
    print("| player | computer | wins | ties | losses | mean length (min) |")
    print("|---|---|---:|---:|---:|---:|")
    for row in table:
        print(f"| {row['player']} | {row['computer']} | {row['wins']} | {row['ties']} | "
              f"{row['losses']} | {row['mean_minutes']:.1f} |")
    if FLAGS.json:
        with open(FLAGS.json, "w") as f:
            json.dump(table, f, indent=1)


if __name__ == "__main__":
    app.run(main)
