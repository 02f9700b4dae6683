"""One line describing the machine a benchmark ran on."""

from __future__ import annotations

import os
import platform
import re

import jax


def machine() -> str:
    """One line: cores, CPU model and its widest vector instructions, load average, JAX
    backend. (Two machines both named "AMD EPYC" ran this project's programs 2.4x apart,
    and rounded differently: one had AVX-512, the other AVX2.)"""
    model = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            info = f.read()
        found = re.search(r"model name\s*:\s*(.*)", info)
        model = found.group(1).strip() if found else model
        found = re.search(r"^flags\s*:\s*(.*)$", info, re.MULTILINE)
        flags = set(found.group(1).split()) if found else set()
        vector = next((name for flag, name in (("avx512f", "AVX-512"), ("avx2", "AVX2"))
                       if flag in flags), None)
        model += f" ({vector})" if vector else ""
    except OSError:
        pass
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    return (f"{os.cpu_count()} cores, {model}; load average {load}; "
            f"JAX {jax.__version__} on {jax.default_backend()} ({jax.devices()[0].device_kind})")
