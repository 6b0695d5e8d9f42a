"""What a report records about the software that produced it."""

from __future__ import annotations

import importlib.metadata
import os
import platform
from pathlib import Path


def package_versions(*packages: str) -> dict[str, str]:
    """Python's version and each installed distribution's, by distribution name."""
    return {"python": platform.python_version(), **{p: importlib.metadata.version(p) for p in packages}}


def machine() -> dict[str, object]:
    """The CPU model (its BLAS kernels set the last bits of a result), core count and system."""
    cpuinfo = Path("/proc/cpuinfo")
    models = [line.split(":", 1)[1].strip() for line in (cpuinfo.read_text().splitlines() if cpuinfo.exists() else [])
              if line.startswith("model name")]
    return {"cpu": models[0] if models else platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "system": platform.platform()}
