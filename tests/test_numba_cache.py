"""Numba's cache (``cache=True``) keys a compiled function on its own file only (a sha256 of the
file's contents, the function's bytecode): code it compiles in from other files — an inlined helper,
a called compiled function, a global constant, the compiler options of :mod:`sail_env.jit` — can
change without the cached machine code being compiled again, and a checkout that pulled such a
change would run the old numbers. So every module with cached compiled functions carries one line

    # compiled in: <files> sha256:<digest of those files, their own such lines left out>

which a change to any of those files must update (this test prints the new line): the module's own
file then changes, and Numba compiles it afresh. The test derives the files from the compiled
functions themselves: every global they read, traced through imports, module-level assignments and
functions (inside ``if``/``try`` blocks too), the attributes they read of a project module, and the
compiled functions they call (directly, through a module or a tuple). A global it cannot trace fails
the test rather than being left out; what it still cannot see is a value reached only through
another object's attribute (``obj.attr`` where ``obj`` is neither a module nor a compiled function).
"""

from __future__ import annotations

import ast
import hashlib
import importlib
import json
import math
import os
import pkgutil
import re
import subprocess
import sys
import types
from pathlib import Path

import numba
import pytest
from numba.core.registry import CPUDispatcher

import sail_env

ROOT = Path(__file__).resolve().parents[1]
#: Always compiled in: the compiler options (not part of Numba's cache key).
OPTIONS = "sail_env/jit.py"
pytestmark = pytest.mark.skipif(numba.config.DISABLE_JIT, reason="no compiled functions without the JIT")
STAMP = re.compile(r"^# compiled in: (?P<files>.+) sha256:(?P<digest>[0-9a-f]{16})\n", re.MULTILINE)


def cached_modules() -> list[str]:
    """Every module of the package that defines a compiled function with a cache (found, not listed)."""
    found = set()
    for info in pkgutil.walk_packages(sail_env.__path__, "sail_env."):
        module = importlib.import_module(info.name)
        if any(isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == info.name
               and type(obj._cache).__name__ != "NullCache" for obj in vars(module).values()):
            found.add(info.name)
    return sorted(found)


CACHED = cached_modules()


def text_of(name: str) -> str:
    """A project file as text, line ends as on Linux (a Windows checkout's CRLF gives the same digest)."""
    return (ROOT / name).read_text(encoding="utf-8").replace("\r\n", "\n")


def digest(files: list[str]) -> str:
    """Of the files without their own stamp lines: stamps can then be updated in any order."""
    sha = hashlib.sha256()
    for name in files:
        sha.update(name.encode() + b"\0" + STAMP.sub("", text_of(name)).encode())
    return sha.hexdigest()[:16]


def source_file(module_name: str) -> str:
    return Path(importlib.import_module(module_name).__file__).relative_to(ROOT).as_posix()


def names_read(node: ast.AST) -> set[str]:
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}


def module_statements(body: list[ast.stmt]) -> list[ast.stmt]:
    """A module's statements, those inside ``if``/``try``/``with``/``for`` blocks included (not the
    bodies of functions and classes: those are read as one definition)."""
    found = []
    for node in body:
        found.append(node)
        for block in ("body", "orelse", "finalbody", "handlers"):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                found += module_statements(getattr(node, block, []))
    return found


def definitions(module_name: str) -> dict[str, set[tuple[str, str]]]:
    """``name -> the (module, name) pairs its definition reads``: ``from X import a as b`` gives
    ``b -> {(X, a)}``; an assignment, function or class of the module gives the module's names its
    statement reads (``_X = int(Slot.X)``: ``Slot``)."""
    tree = ast.parse(text_of(source_file(module_name)))
    found: dict[str, set[tuple[str, str]]] = {}
    for node in module_statements(tree.body):
        if isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                found.setdefault(alias.asname or alias.name, set()).add((node.module, alias.name))
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            found.setdefault(node.name, set()).update((module_name, n) for n in names_read(node))
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)) and node.value is not None:
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for name in (n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)):
                found.setdefault(name, set()).update((module_name, n) for n in names_read(node.value))
    return found


def files_behind(module_name: str, name: str, seen: set[tuple[str, str]]) -> set[str]:
    """The project's files a module-level name's value comes from, followed through every module."""
    if not module_name.startswith("sail_env") or (module_name, name) in seen:
        return set()
    seen.add((module_name, name))
    files = {source_file(module_name)}
    for origin, origin_name in definitions(module_name).get(name, ()):
        files |= files_behind(origin, origin_name, seen)  # a local or a builtin read there adds nothing
    return files


def compiled_in(module_name: str) -> list[str]:
    """The project's files whose code or constants the module's compiled functions compile in."""
    found: set[str] = {OPTIONS}
    seen_names: set[tuple[str, str]] = set()
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
        defined = definitions(home.__name__)
        found.add(source_file(home.__name__))
        names = global_names(dispatcher.py_func.__code__)
        for name in names:
            if name not in vars(home):
                continue  # a builtin, a local or an attribute's name
            value = vars(home)[name]
            if isinstance(value, types.ModuleType):  # `module.attr`: every attribute the code names
                if value.__name__.startswith("sail_env"):
                    for attr in names & vars(value).keys():
                        found |= files_behind(value.__name__, attr, seen_names)
                        todo += dispatchers_in(vars(value)[attr])
                continue
            assert name in defined, (f"{home.__name__}.{name}, read by the compiled {dispatcher.__name__}, has no "
                                     "origin this test can trace: define it by an import or an assignment")
            found |= files_behind(home.__name__, name, seen_names)
            todo += dispatchers_in(value)
    found.discard(source_file(module_name))
    return sorted(found)


def global_names(code: types.CodeType) -> set[str]:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= global_names(const)
    return names


def dispatchers_in(value: object) -> list[CPUDispatcher]:
    items = value if isinstance(value, (tuple, list)) else (value,)
    return [item for item in items if isinstance(item, CPUDispatcher)]


@pytest.mark.parametrize("module_name", CACHED)
def test_a_cached_module_changes_when_what_it_compiles_in_changes(module_name: str) -> None:
    files = compiled_in(module_name)
    line = f"# compiled in: {' '.join(files)} sha256:{digest(files)}\n"
    stamp = STAMP.search(text_of(source_file(module_name)))
    assert stamp is not None and stamp.group(0) == line, (
        f"{source_file(module_name)} must hold the line\n{line}(Numba's cache would keep machine code "
        f"compiled from the old {', '.join(files)})")


def test_every_cached_module_is_found() -> None:
    """A search that found none would check nothing."""
    assert {"sail_env.core.kernels", "sail_env.core.reward", "sail_env.core.delay", "sail_env.physics.pointing",
            "sail_env.physics.rigid3d.flight"} <= set(CACHED)


def test_the_derivation_finds_what_the_kernels_compile_in() -> None:
    """A derivation that found nothing would pass with stamps of jit.py alone."""
    assert set(compiled_in("sail_env.core.kernels")) >= {"sail_env/core/reward.py", "sail_env/core/delay.py",
                                                         "sail_env/core/state.py", "sail_env/physics/pointing.py",
                                                         OPTIONS}
    assert compiled_in("sail_env.core.reward") != [OPTIONS]
    assert "sail_env/physics/constants.py" in compiled_in("sail_env.physics.rigid3d.flight")


#: A read-only install used by someone without a writable home: Numba finds no directory to cache in (its
#: locators' check that a directory can be written is made to fail, as root may write anywhere).
READ_ONLY_EPISODE = """
import json, warnings
import numba.core.caching as caching

def read_only(self):
    raise PermissionError(13, "Read-only file system", self.get_cache_path())

caching._CacheLocator.ensure_cache_path = read_only
with warnings.catch_warnings(record=True) as warned:
    warnings.simplefilter("default")
    import gymnasium as gym
    import sail_env
    env = gym.make("LightSail-v0")
    env.reset(seed=0)
    rewards = [env.step(env.action_space.sample())[1] for _ in range(3)]
print(json.dumps({"warnings": [f"{w.category.__name__}: {w.message}" for w in warned], "rewards": rewards}))
"""


def test_a_read_only_install_without_a_writable_home_compiles_without_a_cache_and_warns_once(tmp_path) -> None:
    environment = {name: value for name, value in os.environ.items()
                   if name not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "LIGHTSAIL_GYM_CACHE")}
    environment.update(HOME="/nonexistent", PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-c", READ_ONLY_EPISODE], cwd=tmp_path, env=environment,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    played = json.loads(run.stdout.splitlines()[-1])
    assert len(played["rewards"]) == 3 and all(math.isfinite(reward) for reward in played["rewards"])
    (warning,) = played["warnings"]
    assert warning.startswith("RuntimeWarning: Numba has no writable directory") and "NUMBA_CACHE_DIR" in warning
