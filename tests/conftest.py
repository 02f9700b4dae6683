"""Compilation settings for the test processes of one session.

- A JAX compilation cache shared by the test processes and the processes they start
  (the commands' own cache, `SC2JAX_COMPILATION_CACHE`, included).
  Many tests build the same program more than once (training runs that are resumed, a
  run trained and then evaluated, every xdist worker compiling a map's step, the
  SC2-API server stepping the program the contract tests compile). A persistent cache in a fresh
  directory per session lets each be compiled once; nothing is shared between
  sessions, so every run checks from scratch. Every program is kept, however quickly it
  compiled: the one-operation programs of eager code (a network's initialisation, ~190 a
  training process) are read back by the next process instead of compiled again (a
  FullyConv initialisation: 1.5 s -> 0.9 s).
- XLA's CPU backend at optimisation level 0 and without the new fusion emitters (unless
  `XLA_FLAGS` is set): the suite is dominated by compiling many small programs. Level 0
  makes them about a third cheaper to compile; the classic elemental emitters take another
  ~40% off (8 map steps: 50 s -> 30 s of compiling; the suite: 466 s -> 337 s on a 2-core
  AMD EPYC VM). The programs compute the same operations (no fast-math either way), only
  slower, which costs the few long-running tests less than it saves.
- Two host devices on the CPU, so that the tests of `sc2jax.environment.engine.xla.devices`
  can split environments over them; every other program runs on the first, as with one.
- The longest files first: xdist hands out whole files (`--dist loadfile`), by default
  those with the most tests first, so test_learning (one test, about 90 s) ran last
  while the other worker idled (548 s of wall time for about 460 s of work on each).
  With `--no-loadscope-reorder` (pyproject.toml) they go in collection order, which
  `pytest_collection_modifyitems` below sets.
"""

import os
import shutil
import tempfile

os.environ.setdefault(
    "XLA_FLAGS", "--xla_backend_optimization_level=0 --xla_cpu_use_fusion_emitters=false")

import jax  # noqa: E402  (after XLA_FLAGS)

jax.config.update("jax_num_cpu_devices", 2)  # Before any test starts the backend.

_ENV = "SC2JAX_TEST_COMPILATION_CACHE"


def pytest_configure(config):
    if not hasattr(config, "workerinput") and _ENV not in os.environ:
        # The controlling process makes the directory; xdist workers inherit it.
        os.environ[_ENV] = tempfile.mkdtemp(prefix="sc2jax-test-jax-cache-")
        config._sc2jax_cache_owner = True
    # The commands the tests start use it too, not the user's (~/.cache/sc2jax/jax).
    os.environ["SC2JAX_COMPILATION_CACHE"] = os.environ[_ENV]
    settings = {"jax_compilation_cache_dir": os.environ[_ENV],
                "jax_persistent_cache_min_compile_time_secs": 0,
                "jax_persistent_cache_min_entry_size_bytes": 0}
    for name, value in settings.items():
        jax.config.update(name, value)
        # Processes the tests start (SC2-API servers, entry points) share the cache too.
        os.environ[name.upper()] = str(value)


def pytest_unconfigure(config):
    if getattr(config, "_sc2jax_cache_owner", False):
        shutil.rmtree(os.environ.pop(_ENV), ignore_errors=True)


# Files that each take a worker a minute or more, longest first (measured on 2 cores,
# 2026-11-30, summed over their tests: about 175, 115, 115, 100, 100, 100, 95, 95, 80,
# 75 and 60 s; test_computer.py, test_melee.py and test_production.py about 60 s each
# on 2026-12-01, the first in one test).
_LONGEST_FIRST = ("test_data_parallel.py", "test_cloning.py", "test_evaluation.py",
                  "test_doc_examples.py", "test_actor_learner.py", "test_training.py",
                  "test_contract.py", "test_loopback.py", "test_mechanics.py",
                  "test_learning.py", "test_computer.py", "test_contract_vmap.py",
                  "test_melee.py", "test_production.py")


def pytest_collection_modifyitems(config, items):
    def rank(item):
        name = item.path.name
        return _LONGEST_FIRST.index(name) if name in _LONGEST_FIRST else len(_LONGEST_FIRST)

    items.sort(key=rank)  # Stable: each file's tests keep their order.
