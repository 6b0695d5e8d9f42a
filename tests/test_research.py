"""research/ stays apart (research/README.md): nothing else imports it, its scripts use the public API
only, and its README maps every script and kept result. These read the files as text; the default run
imports nothing from research/."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESEARCH = ROOT / "research"
#: What the default run, the library and the user's benchmarks are made of.
OUTSIDE = ("sail_env", "agents", "benchmarks", "tests", "train.py", "evaluate.py")


def imported_modules(path: Path) -> list[str]:
    """Every module an ``import`` or ``from … import`` of ``path`` names (relative imports left out)."""
    names = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.append(node.module)
    return names


def private_uses(path: Path) -> list[str]:
    """Where ``path`` reaches a name with one leading underscore: an attribute (``plant._x``), a name
    imported from ``sail_env`` or ``agents``, or a ``getattr`` of one (dunders are Python's, not private)."""
    def private(name: str) -> bool:
        return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))

    found = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Attribute) and private(node.attr):
            found.append(f"{path.name}:{node.lineno} .{node.attr}")
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] in ("sail_env", "agents"):
            found += [f"{path.name}:{node.lineno} {node.module}.{a.name}" for a in node.names if private(a.name)]
        elif isinstance(node, ast.Call) and getattr(node.func, "id", None) == "getattr" and len(node.args) > 1 \
                and isinstance(node.args[1], ast.Constant) and private(str(node.args[1].value)):
            found.append(f"{path.name}:{node.lineno} getattr {node.args[1].value}")
    return sorted(found, key=lambda use: int(use.split(":")[1].split()[0]))


def test_nothing_outside_research_imports_it() -> None:
    """The library, the benchmarks and the default test run never import ``research`` (its tests are
    in research/tests/, which ``testpaths`` leaves out), and the package does not install it."""
    import tomllib

    files = [p for name in OUTSIDE for p in ([ROOT / name] if name.endswith(".py") else (ROOT / name).rglob("*.py"))]
    assert len(files) > 50
    importing = [str(p.relative_to(ROOT)) for p in files
                 if any(m == "research" or m.startswith("research.") for m in imported_modules(p))]
    assert importing == []
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert project["tool"]["pytest"]["ini_options"]["testpaths"] == ["tests"]
    assert not any(p.startswith("research") for p in project["tool"]["setuptools"]["packages"]["find"]["include"])


def test_the_research_scripts_and_their_tests_use_the_public_api_only() -> None:
    """A research script that needs the plant's internals is removed, its result kept as data
    (research/README.md), rather than kept calling them."""
    files = sorted(RESEARCH.rglob("*.py"))
    assert len(files) > 10
    assert [use for path in files for use in private_uses(path)] == []


def test_the_private_use_check_finds_what_the_removed_scripts_did(tmp_path: Path) -> None:
    """The lines that had to go (coast_modal's, at c79a7da) are what the check above reports."""
    script = tmp_path / "old.py"
    script.write_text("from sail_env.physics.noise import _helper\n"
                      "q = plant._coast_params(p, held, middles)\n"
                      "f = getattr(plant, '_piece_propagators')\n"
                      "n = plant.n_states.__class__\n")
    assert private_uses(script) == ["old.py:1 sail_env.physics.noise._helper", "old.py:2 ._coast_params",
                                    "old.py:3 getattr _piece_propagators"]


def test_the_readme_maps_every_script_and_kept_result() -> None:
    readme = (RESEARCH / "README.md").read_text()
    linked = set(re.findall(r"\]\(([^)#\s]+)\)", readme))
    scripts = {p.name for p in RESEARCH.glob("*.py")} - {"__init__.py"}
    results = {f"results/{p.name}" for p in (RESEARCH / "results").iterdir()}
    assert scripts and results
    assert scripts - linked == set() and results - linked == set()
