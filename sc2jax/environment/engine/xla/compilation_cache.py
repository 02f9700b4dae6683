"""JAX's persistent compilation cache, on by default: a program compiled once (a map's
step, a network's update) is read from disk by the next process instead of compiled
again.

The cache lives in `$SC2JAX_COMPILATION_CACHE` if that names a folder, else in
`$XDG_CACHE_HOME/sc2jax/jax` (`~/.cache/sc2jax/jax`). `SC2JAX_COMPILATION_CACHE=0` turns
it off; a cache folder the user set for JAX itself (`JAX_COMPILATION_CACHE_DIR` or
`jax.config`) is left as it is. Programs that compile in under a second are not
written (JAX's default).
"""

from __future__ import annotations

import functools
import logging
import os
import pathlib

import jax

ENV = "SC2JAX_COMPILATION_CACHE"

log = logging.getLogger(__name__)


def cache_dir() -> pathlib.Path | None:
    """The folder the cache uses by these rules (None: turned off)."""
    setting = os.environ.get(ENV, "")
    if setting == "0":
        return None
    if setting not in ("", "1"):
        return pathlib.Path(setting).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "sc2jax" / "jax"


@functools.cache
def use_compilation_cache() -> str | None:
    """Turns the cache on (once per process) and returns its folder, or None when it is
    off or JAX already has a folder of the user's."""
    if jax.config.jax_compilation_cache_dir:
        return None
    folder = cache_dir()
    if folder is None:
        return None
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:  # A read-only home: compile as before.
        log.warning("the compilation cache %s cannot be made (%s); compiling without it",
                    folder, error)
        return None
    jax.config.update("jax_compilation_cache_dir", str(folder))
    return str(folder)
