r"""Simulator throughput: environment steps per second with the paper's random policy.

Every step renders the whole observation (all screen and minimap layers and every
non-spatial observation; written into the last one's buffers, where the layers that
cannot change on the map, such as its zero layers, stay as they are: `Simulator.step`'s
`previous`) and the random agent (SC2LE §4.4) picks its next action from the
last observation's `available_actions`. The measured program is one jitted function that
`lax.scan`s K steps of (random action -> vmapped `Simulator.step`; at one environment
unbatched, as a single environment runs: `per_env`) for `num_envs`
environments, each with its own random key, split over D devices (`--devices`: each
device scans its num_envs / D environments, `sc2jax.environment.engine.xla.devices`; on a CPU, one
host device per core); compilation is excluded (two warm-up calls), each call is timed to
`block_until_ready`, and the median of the repeats is reported. The programs of one
environment count (every map and device count, and SMAX) are timed round-robin, one call
each per round, so a machine whose speed drifts during the run moves them alike and their
ratios hold. Where the rollouts of one count would not fit in memory together (their
carries hold every environment's observation: about 0.65 GB per map at 1,024 environments
of 64² layers), they are timed in groups that do, each group with its own SMAX-3m.

On a CPU, XLA runs a program's kernels on a pool of threads, one per core unless the
`PJRT_NPROC` environment variable says otherwise when JAX starts. Where an agent step is
a few large kernels the pool's threads share them; where its game loops are one kernel
(few environments, `--small_loop_bytes`) the second thread only trades small kernels with
the first: a process with one device and one thread ran FindAndDefeatZerglings at one
environment 1.18-1.33x faster in three runs of the benchmark, 1.15-1.7x in processes side
by side (docs/benchmarks.md). `--threads` lists the pool sizes to measure, each in its
own process: 0 is XLA's default with every `--devices` count; n > 0 times one-device runs
in a process with one CPU device and n threads.

Optionally (`--smax`), JaxMARL's SMAX (an optional, benchmark-only dependency:
`pip install jaxmarl`) is measured the same way on its "3m" scenario, with random
available actions for the three allied marines against its heuristic enemy.

    python -m sc2jax.experiments.benchmark      # a quick set: 2 maps, 1 and 64 envs
    python -m sc2jax.experiments.benchmark --maps=MoveToBeacon --num_envs=1,64 \
        --threads=1,0 --output=docs/benchmarks.md
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence

import jax
from absl import app, flags, logging

from sc2jax.atomic import atomic_write
from sc2jax.checks import non_negative_ints, positive_ints
from sc2jax.environment import MAPS, ObservationFormat, Simulator
from sc2jax.environment.engine.minigames import check_map
from sc2jax.environment.engine.xla.devices import (
    SMALL_LOOP_BYTES,
    compile_small_loops_whole,
    device_sets,
    use_cpu_cores,
)
from sc2jax.experiments.benchmarking.machine import machine
from sc2jax.experiments.benchmarking.memory import (
    FOOTPRINT,
    MEMORY_FRACTION,
    carry_bytes,
    footprint,
    free_memory,
    memory_groups,
)
from sc2jax.experiments.benchmarking.rollouts import (
    THREAD_VARIABLES,
    Result,
    markdown,
    sc2jax_program,
    smax_program,
    steps_per_call,
    time_round_robin,
)
from sc2jax.experiments.reporting.markdown import write_section

FLAGS = flags.FLAGS
QUICK_MAPS = ["MoveToBeacon", "FindAndDefeatZerglings"]
FULL_RUN = ("python -m sc2jax.experiments.benchmark --maps=" + ",".join(MAPS)
            + " --num_envs=1,16,64,1024 --devices=1,0 --repeats=5")
flags.DEFINE_list("maps", QUICK_MAPS, "Mini-games to measure (default: a quick "
                  "representative pair; all seven: " + ",".join(MAPS) + ").")
flags.DEFINE_list("num_envs", ["1", "64"], "Environment counts (one process each).")
flags.DEFINE_integer("screen_size", 64, "Feature-screen resolution.")
flags.DEFINE_integer("minimap_size", 64, "Feature-minimap resolution.")
flags.DEFINE_integer("step_mul", 8, "Game loops per agent step.")
flags.DEFINE_integer("steps", 0, "Agent steps per timed call (K); 0 picks "
                     "max(16, min(2048, 8192 // num_envs)).")
flags.DEFINE_integer("repeats", 3, "Timed calls per measurement (the median is reported).")
flags.DEFINE_list("devices", ["1"], "Device counts to split the environments over, each "
                  "timed (0: every local device; on a CPU, one host device per core). An "
                  "environment count that a device count does not divide runs on one device.")
flags.DEFINE_integer("small_loop_bytes", SMALL_LOOP_BYTES, "On a CPU, while loops that touch "
                     "at most this many bytes are compiled whole "
                     "(`devices.compile_small_loops_whole`); 0 keeps XLA's default.")
flags.DEFINE_list("threads", ["0"], "XLA:CPU thread-pool sizes to measure with, each in its "
                  "own process (`PJRT_NPROC`): 0 is XLA's default (a thread per core) with "
                  "every --devices count; n > 0 times one-device runs only, in a process "
                  "with one CPU device and n threads.")
flags.DEFINE_bool("smax", True, "Also measure JaxMARL's SMAX 3m (skipped if not installed).")
flags.DEFINE_string("output", None, "Markdown file to write the results section into.")
flags.DEFINE_string("results_json", None, "Also write the results as JSON here (the process "
                    "of one --threads size writes them for the run that started it).")

def main(argv: Sequence[str]) -> None:
    del argv
    for name in FLAGS.maps:
        check_map(name)
    counts = positive_ints("num_envs", FLAGS.num_envs)
    if len(set(counts)) != len(counts):
        raise ValueError(f"--num_envs must be distinct positive integers, got {counts}")
    if FLAGS.repeats < 1 or FLAGS.steps < 0:
        raise ValueError(f"--repeats must be >= 1 and --steps >= 0, got {FLAGS.repeats} "
                         f"and {FLAGS.steps}")
    device_counts = non_negative_ints("devices", FLAGS.devices)
    if FLAGS.small_loop_bytes < 0:
        raise ValueError(f"--small_loop_bytes must be >= 0, got {FLAGS.small_loop_bytes}")
    threads = non_negative_ints("threads", FLAGS.threads)
    if len(set(threads)) != len(threads):
        raise ValueError(f"--threads must be distinct integers >= 0, got {threads}")
    settings = [(k, v) for k, v in (
        ("maps", ",".join(FLAGS.maps)), ("num_envs", ",".join(FLAGS.num_envs)),
        ("devices", ",".join(FLAGS.devices)),
        ("screen_size", FLAGS.screen_size), ("minimap_size", FLAGS.minimap_size),
        ("step_mul", FLAGS.step_mul), ("steps", FLAGS.steps), ("repeats", FLAGS.repeats),
        ("small_loop_bytes", FLAGS.small_loop_bytes), ("smax", FLAGS.smax))]
    command = "python -m sc2jax.experiments.benchmark " + " ".join(
        f"--{k}={v}" for k, v in settings + [("threads", ",".join(FLAGS.threads))])
    if len(threads) > 1:
        _each_thread_count(threads, counts, settings, command)
        return
    # The process's own pool, set before JAX starts its backends (`machine()` does).
    for variable in THREAD_VARIABLES:
        os.environ.pop(variable, None)
    if threads[0]:
        os.environ[THREAD_VARIABLES[0]] = str(threads[0])
        jax.config.update("jax_num_cpu_devices", 1)
        device_counts = [1]
    else:
        use_cpu_cores(max(device_counts))
    if FLAGS.small_loop_bytes:
        compile_small_loops_whole(FLAGS.small_loop_bytes)
    fmt = ObservationFormat(screen_size=FLAGS.screen_size, minimap_size=FLAGS.minimap_size)
    before = machine()
    logging.info("Machine: %s", before)
    with_smax, note = FLAGS.smax, ""
    if with_smax:
        try:
            import jaxmarl  # noqa: F401
        except ImportError as e:
            with_smax, note = False, (f"SMAX skipped: jaxmarl is not installed ({e}); "
                                      "`pip install jaxmarl`.")
            logging.warning(note)
    # Plan every count's groups before compiling anything (SMAX's carries are small
    # beside the maps' and are not counted).
    free = free_memory(jax.devices()[0])
    budget = None if free is None else int(MEMORY_FRACTION * free)
    per_env = {name: carry_bytes(Simulator(map_name=name, fmt=fmt, step_mul=FLAGS.step_mul))
               for name in FLAGS.maps}
    plans = []
    for n in counts:
        runs = [(name, devices) for devices in device_sets(n, device_counts)
                for name in FLAGS.maps]
        sizes = [footprint(per_env[name] * n, devices) for name, devices in runs]
        for (name, devices), size in zip(runs, sizes):
            if budget is not None and size > budget:
                raise ValueError(
                    f"--num_envs={n}: {name}'s rollout on {len(devices)} device(s) needs "
                    f"about {size / 1e9:.1f} GB ({FOOTPRINT}x its carry of "
                    f"{per_env[name] * n / 1e9:.2f} GB), more than the {budget / 1e9:.1f} "
                    f"GB it may take ({MEMORY_FRACTION:.0%} of {free / 1e9:.1f} GB free); "
                    "allowed: fewer environments, more devices or smaller layers")
        groups = memory_groups(sizes, budget)
        plans.append((n, [[runs[i] for i in group] for group in groups]))
    results, smax, notes = [], [], [note] if note else []
    for done, (n, groups) in enumerate(plans, 1):
        steps = steps_per_call(n, FLAGS.steps)
        if len(groups) > 1:
            members = "; ".join(f"group {k}: " + ", ".join(
                f"{name} on {len(devices)}" for name, devices in group)
                for k, group in enumerate(groups, 1))
            notes.append(f"At {n} environments the rollouts did not fit in memory together "
                         f"and were timed in {len(groups)} groups, each with its own "
                         f"SMAX-3m; each ratio is against its group's ({members}).")
        for k, group in enumerate(groups, 1):
            programs = [sc2jax_program(name, n, fmt, FLAGS.step_mul, steps, devices)
                        for name, devices in group]
            if with_smax:
                for devices in {len(d): d for _, d in group}.values():
                    programs.append(smax_program(n, FLAGS.step_mul, steps, devices))
            timed = [r._replace(threads=threads[0])
                     for r in time_round_robin(programs, FLAGS.repeats)]
            del programs  # Frees this group's buffers before the next.
            references = {r.devices: r for r in timed if r.name.startswith("SMAX")}
            for r in timed:
                logging.info("%s x%d on %d devices: %.0f agent steps/s, %.0f game steps/s",
                             r.name, n, r.devices, r.agent_steps_per_second,
                             r.game_steps_per_second)
                if r.name.startswith("SMAX"):
                    smax.append(r._replace(name=f"{r.name} (group {k})")
                                if len(groups) > 1 else r)
                else:
                    results.append(r._replace(reference=references.get(r.devices)))
        results.sort(key=lambda r: (FLAGS.maps.index(r.name), counts.index(r.num_envs),
                                    r.devices))
        progress = "" if done == len(plans) else (
            f"Partial: {done} of {len(plans)} environment counts measured so far.")
        section = _section(results, smax, command, before, machine(), notes, progress)
        if FLAGS.results_json:
            _write_json(FLAGS.results_json, {"results": results, "smax": smax,
                                             "notes": notes, "machine": before})
    _report(section)


def _report(section: str) -> None:
    """Prints the results, and after the default quick set how to run the full one."""
    print(section)
    if not any(FLAGS[name].present for name in ("maps", "num_envs", "devices")):
        print(f"\nThat was the quick set. The full run (every map, 1 to 1,024 environments, "
              f"one device and all; about 45 minutes and 12 GB on 2 cores):\n  {FULL_RUN}")


def _write_json(path: str, data: dict) -> None:
    """Writes the results (`Result`s as dicts) to `path` atomically."""
    data = {k: [r.to_json() for r in v] if k in ("results", "smax") else v
            for k, v in data.items()}
    with atomic_write(path) as f:
        json.dump(data, f)


def _each_thread_count(threads: Sequence[int], counts: Sequence[int], settings,
                       command: str) -> None:
    """Runs the measurements of each thread-pool size in a process of its own (XLA sizes
    the pool when JAX starts) and writes their results as one section."""
    results, smax, notes, machines = [], [], [], []
    order = lambda r: (counts.index(r.num_envs), r.devices, threads.index(r.threads))  # noqa: E731
    with tempfile.TemporaryDirectory() as tmp:
        for done, count in enumerate(threads, 1):
            path = os.path.join(tmp, f"threads{count}.json")
            args = [f"--{k}={v}" for k, v in settings] + [
                f"--threads={count}", f"--results_json={path}"]
            logging.info("Thread-pool size %s: %s", count or "XLA default", " ".join(args))
            subprocess.run([sys.executable, "-m", "sc2jax.experiments.benchmark", *args],
                           check=True, stdout=subprocess.DEVNULL)
            with open(path) as f:
                data = json.load(f)
            results += [Result.from_json(r) for r in data["results"]]
            smax += [Result.from_json(r) for r in data["smax"]]
            notes += [n for n in data["notes"] if n not in notes]
            machines.append(data["machine"])
            results.sort(key=lambda r: (FLAGS.maps.index(r.name),) + order(r))
            smax.sort(key=order)
            progress = "" if done == len(threads) else (
                f"Partial: {done} of {len(threads)} thread-pool sizes measured so far.")
            section = _section(results, smax, command, machines[0], machines[-1], notes,
                               progress)
    _report(section)


def _section(results, smax, command: str, before: str, after: str, notes: list,
             progress: str) -> str:
    """The results so far as a markdown section, also written into `--output` (after each
    part of a run, so that a run cut short keeps what it measured)."""
    section = markdown(results, smax, command, before, after,
                       "\n\n".join(notes + [progress] if progress else notes))
    if FLAGS.output:
        write_section(FLAGS.output, section)
    return section


if __name__ == "__main__":
    app.run(main)
