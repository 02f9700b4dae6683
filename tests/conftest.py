"""A JAX compilation cache shared by the test processes of one session.

Many tests build the same program more than once (training runs that are resumed, a run
trained and then evaluated, every xdist worker compiling a map's step). A persistent
compilation cache in a fresh directory per session lets each be compiled once; nothing
is shared between sessions, so every run measures and checks from scratch.
"""

import os
import shutil
import tempfile

import jax

_ENV = "SC2JAX_TEST_COMPILATION_CACHE"


def pytest_configure(config):
    if not hasattr(config, "workerinput") and _ENV not in os.environ:
        # The controlling process makes the directory; xdist workers inherit it.
        os.environ[_ENV] = tempfile.mkdtemp(prefix="sc2jax-test-jax-cache-")
        config._sc2jax_cache_owner = True
    jax.config.update("jax_compilation_cache_dir", os.environ[_ENV])
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)


def pytest_unconfigure(config):
    if getattr(config, "_sc2jax_cache_owner", False):
        shutil.rmtree(os.environ.pop(_ENV), ignore_errors=True)
