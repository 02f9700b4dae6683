"""Training episodes of several A3C runs on one plot (e.g. started from a clone against
from scratch), with reference scores as dashed lines.

    python scripts/compare_runs.py --runs="from the clone=RUN1,from scratch=RUN2" \
        --references="demonstrator=98.12,clone=20.49" --title=CollectMineralShards \
        --output=docs/figures/bc_a3c_shards.png
"""

from __future__ import annotations

import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from sc2jax.atomic import atomic_write  # noqa: E402
from sc2jax.experiments.reporting.metrics_log import read_csv  # noqa: E402
from sc2jax.experiments.reporting.plots import smooth  # noqa: E402


def _pairs(text: str) -> dict[str, str]:
    return dict(item.split("=", 1) for item in text.split(",") if item)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", required=True, help="name=RUN_DIR,...")
    parser.add_argument("--references", default="", help="label=score,...")
    parser.add_argument("--title", required=True)
    parser.add_argument("--smoothing", type=int, default=20)
    parser.add_argument("--output", required=True)
    args = parser.parse_args()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for name, run_dir in _pairs(args.runs).items():
        episodes = read_csv(os.path.join(run_dir, "episodes.csv"))
        ax.plot(episodes["step"], smooth(episodes["score"], args.smoothing), label=name)
    for n, (label, value) in enumerate(_pairs(args.references).items()):
        ax.axhline(float(value), linestyle="--", color=f"C{n + 3}", label=f"{label} ({value})")
    ax.set(title=args.title, xlabel="agent steps",
           ylabel=f"episode score (mean of {args.smoothing} episodes)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    with atomic_write(args.output, "wb") as f:
        fig.savefig(f, format="png")
    print(args.output)


if __name__ == "__main__":
    main()
