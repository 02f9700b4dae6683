"""The paper's Table 1 (SC2LE, Vinyals et al. 2017): scores on the seven mini-games.

`TABLE1[row][map]` is (mean, max) for the baselines and humans, and (best mean, max)
for the trained agents (their "best mean" is the mean of the best of 100 runs).
"""

from __future__ import annotations

from sc2jax.environment.interface.map_names import MINI_GAMES as MAPS

_ROWS = {
    # "<1" in the paper is written 0.5 here.
    "random_policy": ((1, 17, 4, 1, 23, 12, 0.5), (6, 35, 19, 46, 118, 750, 5)),
    "random_search": ((25, 32, 21, 51, 55, 2318, 8), (29, 57, 33, 241, 159, 3940, 46)),
    "deepmind_human": ((26, 133, 46, 41, 729, 6880, 138), (28, 142, 49, 81, 757, 6952, 142)),
    "grandmaster": ((28, 177, 61, 215, 727, 7566, 133), (28, 179, 61, 363, 848, 7566, 133)),
    "atari_net": ((25, 96, 49, 101, 81, 3356, 0.5), (33, 131, 59, 351, 352, 3505, 20)),
    "fullyconv": ((26, 103, 45, 100, 62, 3978, 3), (45, 134, 56, 355, 251, 4130, 42)),
    "fullyconv_lstm": ((26, 104, 44, 98, 96, 3351, 6), (35, 137, 57, 373, 444, 3995, 62)),
}

TABLE1: dict[str, dict[str, tuple[float, float]]] = {
    row: {m: (mean, best) for m, mean, best in zip(MAPS, means, maxes)}
    for row, (means, maxes) in _ROWS.items()
}

NETWORK_ROW = {"atari": "atari_net", "fullyconv": "fullyconv",
               "fullyconv_lstm": "fullyconv_lstm"}
"""The Table 1 row of each sc2jax network that the paper trained (arFullyConv has none)."""

ROW_TITLES = {
    "random_policy": "Random policy", "random_search": "Random search",
    "deepmind_human": "DeepMind human player", "grandmaster": "StarCraft GrandMaster",
    "atari_net": "Atari-net", "fullyconv": "FullyConv", "fullyconv_lstm": "FullyConv LSTM",
}


def paper_rows(map_name: str, rows=tuple(_ROWS)) -> str:
    """The paper's Table 1 entries for one map, one line per row."""
    lines = []
    for row in rows:
        mean, best = TABLE1[row][map_name]
        metric = "best mean" if row in ("atari_net", "fullyconv", "fullyconv_lstm") else "mean"
        lines.append(f"  {ROW_TITLES[row]:<24} {metric:>9} {mean:>7g}   max {best:>7g}")
    return "\n".join(lines)
