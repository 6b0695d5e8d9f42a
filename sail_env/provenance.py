"""What a report records about the software that produced it."""

from __future__ import annotations

import importlib.metadata
import os
import platform
from pathlib import Path


def package_versions(*packages: str) -> dict[str, str]:
    """Python's version and each installed distribution's, by distribution name."""
    return {"python": platform.python_version(), **{p: importlib.metadata.version(p) for p in packages}}


def cpu_model() -> str:
    """The CPU's model (OpenBLAS picks its kernels by it, and they set the last bits of a result): x86's
    model name, or ARM's implementer and part; else the platform's word for it."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        lines = []
    named = [line.split(":", 1)[1].strip() for line in lines
             if line.startswith(("model name", "CPU implementer", "CPU part"))]
    return " ".join(dict.fromkeys(named)) or platform.processor() or platform.machine()


def machine() -> dict[str, object]:
    """The CPU model (:func:`cpu_model`), core count and system."""
    return {"cpu": cpu_model(), "cpus": os.cpu_count(), "system": platform.platform()}
