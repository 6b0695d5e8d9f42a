"""Numba's cache (``cache=True``) keys a compiled function on its own file only (the file's time and
size, the function's bytecode): code it compiles in from other files — an inlined helper, a called
compiled function, a global constant, the compiler options of :mod:`sail_env.jit` — can change
without the cached machine code being compiled again, and a checkout that pulled such a change would
run the old numbers. So every module with cached compiled functions carries one line

    # compiled in: <files> sha256:<digest of those files>

which a change to any of those files must update (this test says how): the module's own file then
changes, and Numba compiles it afresh. The test also derives the files from the compiled functions
themselves (every global they read, followed through the compiled functions they call), so the list
cannot leave one out.
"""

from __future__ import annotations

import ast
import hashlib
import importlib
import re
import types
from pathlib import Path

import numba
import pytest
from numba.core.registry import CPUDispatcher

ROOT = Path(__file__).resolve().parents[1]
#: The modules whose compiled functions are cached.
CACHED = ("sail_env.core.kernels", "sail_env.core.reward", "sail_env.core.delay", "sail_env.physics.pointing",
          "sail_env.physics.rigid3d.flight")
#: Always compiled in: the compiler options (not part of Numba's cache key).
OPTIONS = "sail_env/jit.py"
pytestmark = pytest.mark.skipif(numba.config.DISABLE_JIT, reason="no compiled functions without the JIT")
STAMP = re.compile(r"^# compiled in: (?P<files>.+) sha256:(?P<digest>[0-9a-f]{16})$", re.MULTILINE)


def digest(files: list[str]) -> str:
    sha = hashlib.sha256()
    for name in files:
        sha.update(name.encode() + b"\0" + (ROOT / name).read_bytes())
    return sha.hexdigest()[:16]


def source_file(module_name: str) -> str:
    return str(Path(importlib.import_module(module_name).__file__).relative_to(ROOT))


def origins_of(module: types.ModuleType) -> dict[str, set[str]]:
    """``name -> the modules its value comes from``: ``from X import name`` gives X; a module-level
    assignment gives the origins of the names its value reads (``_X = int(Slot.X)``: ``Slot``'s)."""
    tree = ast.parse(Path(module.__file__).read_text())
    origins: dict[str, set[str]] = {alias.asname or alias.name: {node.module} for node in ast.walk(tree)
                                    if isinstance(node, ast.ImportFrom) and node.module for alias in node.names}
    for node in tree.body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None:
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            read = {n.id for n in ast.walk(node.value) if isinstance(n, ast.Name)}
            sources = set().union(*(origins.get(name, set()) for name in read))
            for name in (n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)):
                origins[name] = origins.get(name, set()) | sources
    return origins


def global_names(code: types.CodeType) -> set[str]:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= global_names(const)
    return names


def compiled_in(module_name: str) -> list[str]:
    """The project's files whose code or constants the module's compiled functions compile in."""
    found: set[str] = {OPTIONS}
    seen: set[object] = set()
    module = importlib.import_module(module_name)
    todo = [obj for obj in vars(module).values()
            if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == module_name]
    while todo:
        dispatcher = todo.pop()
        if dispatcher in seen:
            continue
        seen.add(dispatcher)
        home = importlib.import_module(dispatcher.py_func.__module__)
        origins = origins_of(home)
        if home.__name__ != module_name:
            found.add(source_file(home.__name__))
        for name in global_names(dispatcher.py_func.__code__):
            value = vars(home).get(name)
            if isinstance(value, CPUDispatcher):
                todo.append(value)
            elif not isinstance(value, types.ModuleType):
                found |= {source_file(origin) for origin in origins.get(name, ()) if origin.startswith("sail_env")}
    return sorted(found)


@pytest.mark.parametrize("module_name", CACHED)
def test_a_cached_module_changes_when_what_it_compiles_in_changes(module_name: str) -> None:
    files = compiled_in(module_name)
    line = f"# compiled in: {' '.join(files)} sha256:{digest(files)}"
    stamp = STAMP.search((ROOT / source_file(module_name)).read_text())
    assert stamp is not None and stamp.group(0) == line, (
        f"{source_file(module_name)} must hold the line\n{line}\n(Numba's cache would keep machine code "
        f"compiled from the old {', '.join(files)})")


def test_the_derivation_finds_what_the_kernels_compile_in() -> None:
    """A derivation that found nothing would pass with stamps of jit.py alone."""
    assert set(compiled_in("sail_env.core.kernels")) >= {"sail_env/core/reward.py", "sail_env/core/delay.py",
                                                         "sail_env/core/state.py", OPTIONS}
    assert compiled_in("sail_env.core.reward") != [OPTIONS]
