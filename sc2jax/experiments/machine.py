"""One line describing the machine a benchmark ran on."""

from __future__ import annotations

import os
import platform
import re

import jax


def machine() -> str:
    """One line: cores, CPU model, load average, JAX backend."""
    model = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            found = re.search(r"model name\s*:\s*(.*)", f.read())
        model = found.group(1).strip() if found else model
    except OSError:
        pass
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    return (f"{os.cpu_count()} cores, {model}; load average {load}; "
            f"JAX {jax.__version__} on {jax.default_backend()} ({jax.devices()[0].device_kind})")
