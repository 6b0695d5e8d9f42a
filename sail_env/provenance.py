"""What a report records about the software that produced it."""

from __future__ import annotations

import importlib.metadata
import platform


def package_versions(*packages: str) -> dict[str, str]:
    """Python's version and each installed distribution's, by distribution name."""
    return {"python": platform.python_version(), **{p: importlib.metadata.version(p) for p in packages}}
