"""Forward + backward throughput of the four networks on this machine.

    python -m sc2jax.experiments.benchmark_networks [--resolutions=64,32] [--repeats=5]

For each network and resolution (all 27 screen and 11 minimap layers), times one
jitted gradient of the A3C loss (`make_actor_critic_loss`) on a trajectory of T steps
for B environments, T * B = 32 samples (plus the B bootstrap observations), and
reports samples per second: the median over `--repeats` timed calls after one
warm-up call (compilation excluded). With `--write`, the table replaces the section
"## Networks: forward + backward throughput" of docs/benchmarks.md.
"""

from __future__ import annotations

import datetime
import os
import platform
import statistics
import time
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from absl import app, flags

from sc2jax.checks import check_known, check_positive_int, positive_ints
from sc2jax.environment import ObservationFormat, observation_spec
from sc2jax.environment.interface.dense import DenseAction
from sc2jax.experiments.reporting.markdown import write_section
from sc2jax.losses import Trajectory, make_actor_critic_loss
from sc2jax.networks import NETWORKS, RAW_NETWORKS, make_network
from sc2jax.networks.factory import COMPUTE_DTYPES

SECTION = "## Networks: forward + backward throughput"
DOC = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "benchmarks.md")


def host_init(net, *args, seed: int = 0):
    """Parameters of `net.init`'s shapes drawn on the host (XLA compiles whole-network
    random initialisers slowly on CPU; values do not matter for timing)."""
    rng = np.random.default_rng(seed)
    shapes = jax.eval_shape(net.init, jax.random.key(0), *args)
    return jax.tree.map(lambda s: jnp.asarray(
        rng.normal(0, 0.02, s.shape).astype(s.dtype)), shapes)


def param_count(name: str, size: int = 64) -> int:
    """Parameters of a network at size x size with every feature layer."""
    net, args, _ = _setup(name, size, 1, 1)
    return sum(int(np.prod(s.shape)) for s in jax.tree.leaves(
        jax.eval_shape(net.init, jax.random.key(0), *args)))


def _setup(name: str, size: int, t: int, b: int, dtype: str = "float32"):
    fmt = ObservationFormat(screen_size=size, minimap_size=size)
    net = make_network(name, fmt, dtype=dtype)
    spec = observation_spec(fmt, padded=True)
    rng = np.random.default_rng(0)
    obs = {}
    for key, layers in (("feature_screen", fmt.screen_layers),
                        ("feature_minimap", fmt.minimap_layers)):
        scales = np.array([f.scale for f in layers]).reshape(-1, 1, 1)
        obs[key] = (rng.random((t + 1, b) + spec[key].shape) * scales).astype(np.int32)
    obs["player"] = rng.integers(0, 1000, (t + 1, b, 11), dtype=np.int32)
    obs["available_actions_mask"] = np.ones((t + 1, b, 573), bool)
    obs = {k: jnp.asarray(v) for k, v in obs.items()}
    first = jnp.zeros((t + 1, b), bool)
    if name == "fullyconv_lstm":
        args = (net.initial_carry(b), obs, first)
    else:
        args = (jax.tree.map(lambda x: x[0], obs),)
    return net, args, obs


def benchmark(name: str, size: int, t: int, b: int, repeats: int,
              dtype: str = "float32") -> float:
    """Median samples per second of a jitted A3C gradient, computing in `dtype`."""
    net, args, obs = _setup(name, size, t, b, dtype)
    params = host_init(net, *args)
    action = DenseAction(jnp.zeros((t, b), jnp.int32).at[:, ::2].set(331),  # Move_screen
                         *(jnp.ones((t, b, 2) if i < 3 else (t, b), jnp.int32)
                           for i in range(13)))
    traj = Trajectory(obs, action, jnp.ones((t, b)), jnp.full((t, b), 0.99),
                      jnp.zeros((t + 1, b), bool), None,
                      net.initial_carry(b) if name == "fullyconv_lstm" else None)
    grad = jax.jit(jax.grad(make_actor_critic_loss(net), has_aux=True))
    jax.block_until_ready(grad(params, traj))  # compile + warm-up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(grad(params, traj))
        times.append(time.perf_counter() - start)
    return t * b / statistics.median(times)


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


FEATURE_NETWORKS = [name for name in NETWORKS if name not in RAW_NETWORKS]
"""The networks this benchmark times (those of the feature interface)."""
_NETWORKS = flags.DEFINE_list("networks", FEATURE_NETWORKS,
                              f"Networks, of {FEATURE_NETWORKS}.")
_RESOLUTIONS = flags.DEFINE_list("resolutions", ["64", "32"], "Screen and minimap sizes.")
_STEPS = flags.DEFINE_integer("steps", 4, "T, steps per trajectory.")
_ENVS = flags.DEFINE_integer("envs", 8, "B, environments.")
_REPEATS = flags.DEFINE_integer("repeats", 5, "Timed calls (the median is reported).")
_DTYPES = flags.DEFINE_list("dtypes", ["float32"], f"Compute dtypes, of {list(COMPUTE_DTYPES)}; "
                            "each is a column.")
_WRITE = flags.DEFINE_bool("write", False, "Update docs/benchmarks.md.")


def main(argv: Sequence[str]) -> None:
    del argv
    check_known("network", _NETWORKS.value, FEATURE_NETWORKS)
    check_known("dtype", _DTYPES.value, COMPUTE_DTYPES)
    dtypes = _DTYPES.value
    resolutions = positive_ints("resolutions", _RESOLUTIONS.value)
    steps, envs, repeats = _STEPS.value, _ENVS.value, _REPEATS.value
    for name, value in (("steps", steps), ("envs", envs), ("repeats", repeats)):
        check_positive_int(name, value)
    rows = []
    for name in _NETWORKS.value:
        for size in resolutions:
            rates = []
            for dtype in dtypes:  # In turn, so that each pair is measured side by side.
                rates.append(benchmark(name, size, steps, envs, repeats, dtype))
                print(f"{name:15s} {size:3d}x{size:<3d} {dtype:8s} {rates[-1]:9.1f} "
                      f"samples/s", flush=True)
            rows.append((name, size, rates))
    columns = [f"{d} samples/s" for d in dtypes]
    table = [f"| network | resolution | {' | '.join(columns)} |",
             "|---|---|" + "---|" * len(dtypes)]
    table += [f"| {n} | {s}x{s} | {' | '.join(f'{v:.1f}' for v in r)} |" for n, s, r in rows]
    text = "\n".join([
        SECTION, "",
        f"Command: `python -m sc2jax.experiments.benchmark_networks "
        f"--dtypes={','.join(dtypes)} --repeats={repeats} --write` "
        f"(T={steps}, B={envs}: {steps * envs} samples per step; "
        f"median of {repeats} timed calls after a warm-up; all 27 screen and 11 "
        "minimap layers; one jitted gradient of the A3C loss).", "",
        f"Machine: CPU, `nproc` = {os.cpu_count()}, {_cpu_model()}; jax {jax.__version__} "
        f"({jax.default_backend()}). Date: {datetime.date.today().isoformat()}.", "",
        *table, ""])
    if _WRITE.value:
        write_section(DOC, text)
    print(text)


if __name__ == "__main__":
    app.run(main)
