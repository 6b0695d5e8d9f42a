"""The package's layout: analysis code stays off the runtime path."""

from __future__ import annotations

import subprocess
import sys

RUNTIME = ("import sail_env, sail_env.envs.planar, sail_env.envs.rigid3d, sail_env.envs.vector, agents.evaluation, "
           "agents.training, agents.grid, agents.tuning")


def test_the_envs_core_and_agents_never_import_the_analysis_modules() -> None:
    """``sail_env.analysis`` (the paper, the jitter levels' derivation, the 3D tables) is imported
    only by its own commands and the tests: a user's ``import sail_env`` does not load it."""
    check = f"{RUNTIME}; import sys; print(sorted(m for m in sys.modules if m.startswith('sail_env.analysis')))"
    done = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"
