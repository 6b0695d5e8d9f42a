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


def test_the_core_knows_no_concrete_sail_model() -> None:
    """The episode core and the spec take a plant through its contract (``sail_env.core.plant``):
    a new sail model needs no change in ``sail_env.core``."""
    import ast
    from pathlib import Path

    concrete = ("sail_env.physics.planar_plant", "sail_env.physics.rigid3d", "PlanarPlant", "RigidPlant", "UncertainPlant")
    for path in sorted(Path("sail_env/core").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or "", *(alias.name for alias in node.names)]
                assert not any(name.startswith(concrete) for name in names), f"{path} imports {names}"
