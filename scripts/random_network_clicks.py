"""What fresh FullyConv networks do on MoveToBeacon, by resolution (docs/results.md).

    python scripts/random_network_clicks.py --resolution=64 --networks=200

Why the paper's random search (§4.3: the best of many randomly initialised FullyConv
policies at a low softmax temperature) can play MoveToBeacon: a near-deterministic
policy plays the argmax of its logits, so it plays the task only if its argmax picks
`select_army` while the marine is unselected, a screen move once it is selected, and a
pixel of the beacon. For each of N fresh networks (every feature layer, all 573
functions, Flax's default initialisers as in `sc2jax.networks`), on the first observation
of 8 episodes and on the observation after `select_army`, this prints how often the
argmax of the available functions is `select_army` (first observation) and a screen move
(Move_screen, Attack_screen or Smart_screen; second observation), how often the screen
argmax lands on the beacon and on the marine (second observation), and which networks do
all three in most of the 8 episodes.
"""

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

from sc2jax.environment import FUNCTIONS, ObservationFormat
from sc2jax.environment.engine.compiled import simulator
from sc2jax.environment.interface import dense
from sc2jax.environment.interface.features import PlayerRelative
from sc2jax.networks.factory import make_network

EPISODES = 8
SCREEN_MOVES = [FUNCTIONS[name].id for name in ("Move_screen", "Attack_screen",
                                                "Smart_screen")]
SELECT_ARMY = FUNCTIONS["select_army"].id


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--resolution", type=int, default=64)
    parser.add_argument("--networks", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0, help="network i uses PRNGKey(seed + i)")
    args = parser.parse_args()
    if args.networks < 1:
        parser.error(f"--networks must be positive, got {args.networks}")
    res = args.resolution
    fmt = ObservationFormat(res, res)  # raises for a resolution outside 16..256
    sim = simulator("MoveToBeacon", fmt, 8, 0, 1.0, 0.99, False)
    net = make_network("fullyconv", fmt)

    state, first = jax.vmap(sim.reset)(jax.random.split(jax.random.PRNGKey(123), EPISODES))
    select = dense.zeros((EPISODES,))._replace(
        function=jnp.full((EPISODES,), SELECT_ARMY, jnp.int32))
    _, selected = jax.vmap(sim.step)(state, select)
    obs1, obs2 = first.observation, selected.observation
    layer = [f.name for f in fmt.screen_layers].index("player_relative")
    relative = np.asarray(obs2["feature_screen"][:, layer])  # [E, H, W]
    available1 = np.asarray(obs1["available_actions_mask"])
    available2 = np.asarray(obs2["available_actions_mask"])
    print(f"{res}x{res}: beacon pixels per episode "
          f"{(relative == PlayerRelative.NEUTRAL).sum((1, 2)).tolist()}")

    @jax.jit
    def outputs(key):
        params = net.init(key, jax.tree.map(lambda x: x[:1], obs1))
        out1, out2 = net.apply(params, obs1), net.apply(params, obs2)
        return out1.function_logits, out2.function_logits, out2.argument_logits[0].logits

    def argmax_available(logits, available):
        return np.argmax(np.where(available, np.asarray(logits), -np.inf), axis=-1)

    start = time.time()
    counts = dict(select_first=0.0, move_once_selected=0.0, beacon=0.0, marine=0.0)
    plays = []
    for i in range(args.networks):
        f1, f2, screen = outputs(jax.random.PRNGKey(args.seed + i))
        pixel = np.asarray(jnp.argmax(screen, axis=-1))
        under = relative[np.arange(EPISODES), pixel // res, pixel % res]
        selects = argmax_available(f1, available1) == SELECT_ARMY
        moves = np.isin(argmax_available(f2, available2), SCREEN_MOVES)
        beacon = under == PlayerRelative.NEUTRAL
        for name, hit in (("select_first", selects), ("move_once_selected", moves),
                          ("beacon", beacon), ("marine", under == PlayerRelative.SELF)):
            counts[name] += hit.mean() / args.networks
        if selects.mean() > 0.5 and moves.mean() > 0.5 and beacon.mean() > 0.5:
            plays.append(args.seed + i)
    print(f"{args.networks} networks [{time.time() - start:.0f} s]: select_army first "
          f"{counts['select_first']:.3f}, a screen move first once selected "
          f"{counts['move_once_selected']:.3f}, screen argmax on the beacon "
          f"{counts['beacon']:.3f}, on the marine {counts['marine']:.3f}")
    print(f"networks that do all three in most episodes: {plays}")


if __name__ == "__main__":
    main()
