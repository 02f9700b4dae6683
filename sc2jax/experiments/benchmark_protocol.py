r"""The StarCraft II API's cost: agent steps through the protocol against in-process.

For each map, one agent plays the same random policy (uniform over the available
functions, then uniform arguments) for `--steps` agent steps:
- in process: `make(map)`, the simulator's `SC2Env`;
- through the protocol: a `GameEnv` driving the simulator's SC2-API server in its own
  process, started by the launcher from an install layout (`--write-sc2path`), exactly as
  the real game would be: every step is RequestAction, RequestStep and
  RequestObservation over a loopback websocket, with every feature layer sent and
  decoded.

It also times what one observation costs: encoding it (the server), parsing the
serialized `Response` (protobuf's fast runtime) and decoding it into PySC2's observation
dict (the client), and the same for each map's unit lists (`raw_data.units` into
`feature_units` and `raw_units`); and the split loop's actors: one `HostActor` acting
with one batched policy call for 1, 4 and 16 server processes (`GameEnvBatch`).
Compilation is excluded (warm-up steps and a warm-up unroll).

    python -m sc2jax.experiments.benchmark_protocol --output=docs/benchmarks.md
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import statistics
import tempfile
import time
from collections.abc import Sequence

import jax
import numpy as np
from absl import app, flags, logging

from sc2jax.environment import make
from sc2jax.environment.engine.minigames import check_map
from sc2jax.environment.engine.observation import api_units
from sc2jax.environment.interface.functions import FUNCTIONS, FunctionCall
from sc2jax.environment.sc2api import proto_observation
from sc2jax.environment.sc2api.controller import Controller
from sc2jax.environment.sc2api.game_env import GameEnv, GameEnvBatch
from sc2jax.environment.sc2api.launcher import launch
from sc2jax.environment.sc2api.protos import runtime, sc2api
from sc2jax.environment.server.install_layout import write_sc2path
from sc2jax.experiments.benchmarking.machine import machine
from sc2jax.experiments.reporting.markdown import write_section
from sc2jax.experiments.training import trainer
from sc2jax.experiments.training.config import TrainConfig
from sc2jax.experiments.training.host_actor import HostActor

FLAGS = flags.FLAGS
flags.DEFINE_list("maps", ["MoveToBeacon", "CollectMineralShards"], "Mini-games to measure.")
flags.DEFINE_integer("screen_size", 64, "Feature-screen resolution.")
flags.DEFINE_integer("minimap_size", 64, "Feature-minimap resolution.")
flags.DEFINE_integer("steps", 500, "Timed agent steps per backend.")
flags.DEFINE_integer("warmup", 20, "Untimed agent steps first (compilation).")
flags.DEFINE_integer("parses", 200, "Repeats for the cost of one observation.")
flags.DEFINE_list("actor_processes", ["1", "4", "16"],
                  "Server processes one HostActor acts for (0 or empty: skip).")
flags.DEFINE_string("actor_network", "fullyconv", "The network the actor acts with.")
flags.DEFINE_alias("actor_agent", "actor_network")  # The old name.
flags.DEFINE_integer("actor_unrolls", 5, "Timed K-step unrolls per actor measurement.")
flags.DEFINE_integer("unroll_length", 40, "K.")
flags.DEFINE_string("output", None, "Markdown file to write the results section into.")

SECTION = "## The SC2 API: protocol against in-process"


def random_call(rng: np.random.Generator, available: np.ndarray, types) -> FunctionCall:
    """The paper's random policy on the host: a uniform available function, then
    uniform arguments."""
    func = FUNCTIONS[int(rng.choice(available))]
    args = [[int(rng.integers(s)) for s in types[t.id].sizes] if t.is_point
            else [int(rng.integers(types[t.id].sizes[0]))] for t in func.args]
    return FunctionCall(func.id, args)


def steps_per_second(env, steps: int, warmup: int, seed: int = 0) -> float:
    """Agent steps per second of a dm_env environment under the random policy."""
    rng = np.random.default_rng(seed)
    types = env.fmt.types if hasattr(env, "fmt") else env.simulator.fmt.types
    timestep = env.reset()
    start = None
    for i in range(warmup + steps):
        if i == warmup:
            start = time.perf_counter()
        timestep = env.step(random_call(rng, timestep.observation["available_actions"], types))
    return steps / (time.perf_counter() - start)


def observation_costs(controller: Controller, map_name: str, fmt,
                      repeats: int) -> dict[str, float]:
    """One observation's size, and the median seconds to encode it (server), to parse
    the reply and to decode it into PySC2's observation dict (client)."""
    reply = controller.request("observation", sc2api.RequestObservation())
    data = sc2api.Response(observation=reply).SerializeToString()
    sim = make(map_name, seed=0, screen_size=fmt.screen_size,
               minimap_size=fmt.minimap_size).simulator
    padded = jax.device_get(jax.jit(sim.reset)(jax.random.PRNGKey(0))[1].observation)
    times = {"encode": [], "parse": [], "decode": []}
    for _ in range(repeats):
        t0 = time.perf_counter()
        proto_observation.encode(padded, sim.fmt)
        t1 = time.perf_counter()
        parsed = sc2api.Response.FromString(data)
        t2 = time.perf_counter()
        proto_observation.decode(parsed.observation, fmt, map_name)
        t3 = time.perf_counter()
        for key, seconds in (("encode", t1 - t0), ("parse", t2 - t1), ("decode", t3 - t2)):
            times[key].append(seconds)
    return {"bytes": len(data), **{k: statistics.median(v) for k, v in times.items()}}


def unit_list_costs(map_name: str, fmt, repeats: int) -> dict[str, float]:
    """The unit list of a map's first observation: its units, its bytes in
    `raw_data.units`, and the median seconds to encode it (server) and to parse and
    decode it into `feature_units` and `raw_units` (client)."""
    fmt = dataclasses.replace(fmt, use_feature_units=True, use_raw_units=True)
    sim = make(map_name, seed=0, screen_size=fmt.screen_size,
               minimap_size=fmt.minimap_size).simulator
    state = jax.jit(sim.reset)(jax.random.PRNGKey(0))[0]
    api = jax.device_get(jax.jit(lambda s: api_units(s, sim.renderer))(state))
    map_size = sim.renderer.geometry.size
    times = {"encode": [], "decode": []}
    for _ in range(repeats):
        t0 = time.perf_counter()
        raw = sc2api.ObservationRaw()
        proto_observation.encode_units(api, raw)
        data = raw.SerializeToString()
        t1 = time.perf_counter()
        units = sc2api.ObservationRaw.FromString(data).units
        proto_observation.decode_units(units, fmt, tuple(state.camera.tolist()), map_size)
        t2 = time.perf_counter()
        times["encode"].append(t1 - t0)
        times["decode"].append(t2 - t1)
    return {"units": len(units), "bytes": len(data),
            **{k: statistics.median(v) for k, v in times.items()}}


def actor_steps_per_second(root, map_name: str, processes: int, agent_name: str,
                           sizes: dict, unroll_length: int, unrolls: int) -> float:
    """Agent steps per second of one `HostActor` acting, with batched inference, for
    `processes` server processes (policy inference and every protocol round trip
    included; no learning)."""
    config = TrainConfig(map_name=map_name, agent=agent_name, num_envs=processes,
                         unroll_length=unroll_length, **sizes)
    agent = trainer.build(config)
    with concurrent.futures.ThreadPoolExecutor(processes) as pool:
        games = list(pool.map(lambda _: launch(root), range(processes)))
    batch = GameEnvBatch([GameEnv(lambda game=game: game.controller, map_name,
                                  random_seed=seed, **sizes)
                          for seed, game in enumerate(games)])
    try:
        actor = HostActor(batch, agent.core, unroll_length)
        params = agent.initial_state(jax.random.PRNGKey(0)).learner.params
        actor.unroll(params)  # Compiles, on the actor and in every server.
        start = time.perf_counter()
        for _ in range(unrolls):
            actor.unroll(params)
        return processes * unroll_length * unrolls / (time.perf_counter() - start)
    finally:
        batch.close()
        for game in games:
            game.close()


def main(argv: Sequence[str]) -> None:
    del argv
    for name in FLAGS.maps:
        check_map(name)
    for name in ("steps", "parses"):
        if getattr(FLAGS, name) < 1:
            raise ValueError(f"--{name} must be positive, got {getattr(FLAGS, name)}")
    sizes = dict(screen_size=FLAGS.screen_size, minimap_size=FLAGS.minimap_size)
    before = machine()
    rows, costs = [], None
    with tempfile.TemporaryDirectory() as tmp:
        root = write_sc2path(tmp)
        for name in FLAGS.maps:
            local = steps_per_second(make(name, seed=0, **sizes), FLAGS.steps, FLAGS.warmup)
            game = launch(root)
            env = GameEnv(lambda game=game: game.controller, name, random_seed=0, **sizes)
            try:
                remote = steps_per_second(env, FLAGS.steps, FLAGS.warmup)
                if costs is None:
                    costs = observation_costs(game.controller, name, env.fmt, FLAGS.parses)
            finally:
                env.close()
                game.close()
            logging.info("%s: %.0f in process, %.0f through the protocol", name, local, remote)
            rows.append((name, local, remote, unit_list_costs(name, env.fmt, FLAGS.parses)))
    counts = [int(n) for n in FLAGS.actor_processes if int(n) > 0]
    actors = []
    with tempfile.TemporaryDirectory() as tmp:
        root = write_sc2path(tmp)
        for n in counts:
            rate = actor_steps_per_second(root, FLAGS.maps[0], n, FLAGS.actor_network, sizes,
                                          FLAGS.unroll_length, FLAGS.actor_unrolls)
            logging.info("actor over %d server processes: %.0f agent steps/s", n, rate)
            actors.append((n, rate))
    command = ("python -m sc2jax.experiments.benchmark_protocol "
               f"--maps={','.join(FLAGS.maps)} --screen_size={FLAGS.screen_size} "
               f"--minimap_size={FLAGS.minimap_size} --steps={FLAGS.steps} "
               f"--warmup={FLAGS.warmup} --parses={FLAGS.parses} "
               f"--actor_processes={','.join(FLAGS.actor_processes)} "
               f"--actor_network={FLAGS.actor_network} --actor_unrolls={FLAGS.actor_unrolls} "
               f"--unroll_length={FLAGS.unroll_length}")
    lines = [SECTION, "", f"Command: `{command}`", "",
             f"- Machine before the run: {before}", f"- Load after the run: {machine()}",
             f"- protobuf runtime: {runtime()}", "",
             "| Map | In process (agent steps/s) | Through the protocol (agent steps/s) | "
             "Ratio |", "|---|---:|---:|---:|"]
    lines += [f"| {n} | {a:,.0f} | {b:,.0f} | {b / a:.2f} |" for n, a, b, _ in rows]
    lines += ["", f"One {FLAGS.screen_size}x{FLAGS.minimap_size} observation of "
              f"{FLAGS.maps[0]} (every layer) is {costs['bytes']:,} bytes. The server "
              f"encodes it in {costs['encode'] * 1e3:.3f} ms; the client parses it in "
              f"{costs['parse'] * 1e3:.3f} ms and decodes it into PySC2's observation dict "
              f"in {costs['decode'] * 1e3:.3f} ms (medians of {FLAGS.parses}).", "",
              "Unit lists (`use_feature_units`, `use_raw_units`; the join's `raw`) add the "
              "first observation's `raw_data.units`: the server encodes and serializes them, "
              "the client parses them and builds both lists (medians of "
              f"{FLAGS.parses}):", "",
              "| Map | Units | Bytes | Encode (ms) | Parse + decode (ms) |",
              "|---|---:|---:|---:|---:|"]
    lines += [f"| {n} | {u['units']} | {u['bytes']:,} | {u['encode'] * 1e3:.3f} | "
              f"{u['decode'] * 1e3:.3f} |" for n, _, _, u in rows]
    if actors:
        lines += ["", f"One `HostActor` acting for N server processes of {FLAGS.maps[0]} "
                  f"with one batched {FLAGS.actor_network} policy call per step "
                  f"(K={FLAGS.unroll_length}, {FLAGS.actor_unrolls} timed unrolls; the "
                  f"actors of the split loop, learning excluded):", "",
                  "| Server processes | Agent steps/s |", "|---:|---:|"]
        lines += [f"| {n} | {rate:,.0f} |" for n, rate in actors]
    section = "\n".join(lines) + "\n"
    print(section)
    if FLAGS.output:
        write_section(FLAGS.output, section)


if __name__ == "__main__":
    app.run(main)
