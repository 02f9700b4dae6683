"""How fast the viewer draws: human views per second, and a 240-step episode to video.

    python scripts/render_speed.py --maps=MoveToBeacon,DefeatZerglingsAndBanelings,BuildMarines

For each map at 64²: the human view (`engine.human_view`, 256 pixels wide) of one state
per call and of 64 states in one vmapped call, in pictures per second (the median of
--rounds rounds, each timing --draws calls after a compiled first one); then one
recorded episode of the random policy turned into a video as `evaluate --video` does:
replayed and drawn (`frames.episode_pictures`, compiled beforehand), laid out
(`frames.episode_frames`) and written as MP4 and as GIF (`video.write_video`). Prints a
markdown table.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import jax

from sc2jax.environment.engine.compiled import simulator
from sc2jax.environment.engine.human_view import HumanView
from sc2jax.environment.interface.specs import ObservationFormat
from sc2jax.experiments.training import evaluation
from sc2jax.experiments.viewer import frames, video


def _rate(fn, arg, draws: int, rounds: int, per_call: int) -> float:
    jax.block_until_ready(fn(arg))
    rates = []
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(draws):
            out = fn(arg)
        jax.block_until_ready(out)
        rates.append(draws * per_call / (time.perf_counter() - start))
    return statistics.median(rates)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", default="MoveToBeacon,DefeatZerglingsAndBanelings,"
                                          "BuildMarines")
    parser.add_argument("--width", type=int, default=256)
    parser.add_argument("--draws", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--batch", type=int, default=64)
    args = parser.parse_args()
    fmt = ObservationFormat(screen_size=64, minimap_size=64)
    layers = frames.parse_layers(frames.DEFAULT_LAYERS)
    print(f"| map | one view / s | {args.batch} views in one call / s | episode steps | "
          f"replay and draw (s) | frames laid out (s) | MP4 (s) | GIF (s) | total to MP4 "
          f"(s) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for map_name in args.maps.split(","):
        sim = simulator(map_name, fmt, 8, 0, 1.0, 1.0, False)
        view = HumanView(sim, args.width)
        keys = jax.random.split(jax.random.PRNGKey(0), args.batch)
        states, _ = jax.jit(jax.vmap(sim.reset))(keys)
        one = jax.tree.map(lambda x: x[0], states)
        single = _rate(jax.jit(view.draw), one, args.draws, args.rounds, 1)
        batched = _rate(jax.jit(jax.vmap(view.draw)), states, max(1, args.draws // 4),
                        args.rounds, args.batch)
        core = evaluation.policy_core(evaluation.make_policy("random", map_name, fmt))
        episode = evaluation.record_episodes(sim, core, None, 1, seed=0)[0]
        frames.episode_pictures(episode, args.width, layers)  # Compiled here.
        start = time.perf_counter()
        drawn = frames.episode_pictures(episode, args.width, layers)
        t_draw = time.perf_counter() - start
        start = time.perf_counter()
        clip = frames.episode_frames(episode, drawn, layers)
        t_layout = time.perf_counter() - start
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            video.write_video(os.path.join(tmp, "a.mp4"), clip)
            t_mp4 = time.perf_counter() - start
            start = time.perf_counter()
            video.write_video(os.path.join(tmp, "a.gif"), clip)
            t_gif = time.perf_counter() - start
        print(f"| {map_name} | {single:,.0f} | {batched:,.0f} | {episode.num_steps} | "
              f"{t_draw:.2f} | {t_layout:.2f} | {t_mp4:.2f} | {t_gif:.2f} | "
              f"{t_draw + t_layout + t_mp4:.2f} |", flush=True)



if __name__ == "__main__":
    main()
