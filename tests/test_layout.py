"""The package's layout: analysis code stays off the runtime path."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

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

    concrete = ("sail_env.physics.planar", "sail_env.physics.rigid3d", "PlanarPlant", "RigidPlant", "UncertainPlant")
    for path in sorted(Path("sail_env/core").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or "", *(alias.name for alias in node.names)]
                assert not any(name.startswith(concrete) for name in names), f"{path} imports {names}"


#: Each package's floor: a module imports only modules on its floor or below (physics ← core ←
#: envs ← agents ← scripts), and no chain of imports returns to where it started. A package of
#: scripts added beside ``benchmarks`` gets its floor here.
FLOORS = {
    "sail_env.jit": 0, "sail_env.provenance": 0,
    "sail_env.physics": 1,
    "sail_env.core": 2,
    "sail_env.envs": 3, "sail_env.tasks": 3, "sail_env": 3, "sail_env.analysis": 3,
    "agents": 4,
    "benchmarks": 5,
}


def import_graph(root: Path, packages: tuple[str, ...]) -> dict[str, set[str]]:
    """Every module of ``packages`` (under ``root``) and the modules of ``packages`` it imports,
    at module level or inside a function, read from the source: ``from p import name`` imports
    ``p.name`` where that is a module, ``p`` (its ``__init__``) otherwise; the parent packages a
    submodule's import runs are not counted."""
    import ast

    modules = {}
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path

    def known(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for module, path in modules.items():
        graph[module] = imported = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [known(alias.name) for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    package = module.split(".")[: len(module.split(".")) - (path.name != "__init__.py")]
                    base = ".".join(package[: len(package) - node.level + 1] + ([base] if base else []))
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else known(base)
                           for alias in node.names]
            else:
                continue
            imported.update(target for target in targets if target and target != module)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for other in sorted(graph.get(node, ())):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while not component or component[-1] != node:
                component.append(stack.pop())
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def floor(module: str) -> int:
    """The floor of the longest :data:`FLOORS` prefix of ``module``."""
    owner = max((name for name in FLOORS if module == name or module.startswith(name + ".")), key=len)
    return FLOORS[owner]


def test_the_import_graph_has_no_cycles_and_runs_downwards() -> None:
    """No module imports itself back through others (lazy imports included), and none imports
    from a floor above its own (:data:`FLOORS`): a new sail model, disturbance or task is added
    without touching the floors below it."""

    graph = import_graph(Path(__file__).parents[1], ("sail_env", "agents", "benchmarks"))
    assert len(graph) > 50 and sum(map(len, graph.values())) > 150, "the scan found too little"
    assert cycles(graph) == []
    upward = sorted((module, other) for module, imported in graph.items() for other in imported
                    if floor(other) > floor(module))
    assert upward == []


def test_the_graph_scan_sees_a_lazy_circular_import(tmp_path) -> None:
    """The scan itself: a circle closed by an import inside a function, through a relative import,
    is found, and so is an import from a floor above."""

    package = tmp_path / "sail_env"
    (package / "physics").mkdir(parents=True)
    (package / "core").mkdir()
    (package / "__init__.py").write_text("")
    (package / "physics" / "__init__.py").write_text("")
    (package / "core" / "__init__.py").write_text("")
    (package / "physics" / "base.py").write_text("def load():\n    from . import plugin\n")
    (package / "physics" / "plugin.py").write_text("from sail_env.physics.base import load\n")
    (package / "physics" / "lower.py").write_text("import sail_env.core.spec\n")
    (package / "core" / "spec.py").write_text("from sail_env.physics import lower\n")
    graph = import_graph(Path(tmp_path), ("sail_env",))
    assert cycles(graph) == [["sail_env.core.spec", "sail_env.physics.lower"],
                             ["sail_env.physics.base", "sail_env.physics.plugin"]]
    assert floor("sail_env.physics.lower") < floor("sail_env.core.spec")


#: The sail models' packages in ``sail_env.physics``: siblings, as brax's pipelines are.
MODELS = ("sail_env.physics.planar", "sail_env.physics.rigid3d")


def test_the_sail_models_are_siblings_on_generic_physics() -> None:
    """No sail model imports another, and the generic physics (the linear machinery, the validators,
    the disturbances, the seed's design point) imports none: each model supplies what the generic
    code needs (its push terms, velocity rows, mode rates), so a new model is one package beside
    them. ``sail_env.physics`` itself re-exports the planar names for short imports."""

    graph = import_graph(Path(__file__).parents[1], ("sail_env",))

    def model_of(module: str) -> str | None:
        return next((model for model in MODELS if module == model or module.startswith(model + ".")), None)

    crossing = sorted((module, other) for module, imported in graph.items() for other in imported
                      if module.startswith("sail_env.physics.") and model_of(other) not in (None, model_of(module)))
    assert crossing == []
