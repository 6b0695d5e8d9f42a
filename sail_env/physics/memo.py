"""Tables built once: per process, and across processes on disk.

Building a 3D realistic task integrates flights and runs surface quadratures: ~0.75 s for
``LightSail3DRealistic-v1``, ~1.1 s more for ``LightSailUncertain-v1``'s curvature table. Every
``gym.make`` of the same task needs the same tables: the envs of a vector, an evaluation, a benchmark
grid's cells, every worker of a ``SubprocVecEnv``, every new process. :func:`built_once` keeps what a
factory built for each distinct tuple of arguments (frozen configurations and numbers, hashable and
compared by value) and hands out the same object, its arrays made read-only, so that no plant can
change another's tables.

It also stores each table on disk (a pickle of the table and its key, written atomically, readable by
all) and loads it in later processes: the key is a digest of the factory, its arguments' ``repr`` and
:func:`code_version` (this package's physics sources as the process imported them, the versions of
Python, NumPy, SciPy and Numba, the CPU and the features NumPy dispatches on, each BLAS library's
version and kernel), so a change to any of them builds afresh; a file whose stored key differs is
built again too. A loaded table is the built one to the bit. ``LIGHTSAIL_GYM_CACHE`` names the
directory (default ``$XDG_CACHE_HOME/lightsail-gym``, else ``~/.cache/lightsail-gym``); ``off`` (or
``0``, ``false``, ``no``, ``none``, empty) keeps tables in memory only. A directory that cannot be
written, or a table that cannot be stored, is kept in memory only; a file that cannot be read is
built again. Of each kind of table the :data:`TABLES_KEPT` most recently used files are kept
(0.03–2 MB each), the older removed. The files are pickles, as Numba's cache is: a directory others
can write is not one to load from. Every array is read-only, the splines' coefficients included;
the tables' few Python lists are not, and nothing writes to them.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
import platform
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np

#: How many distinct tables of one kind a process keeps, and the disk (the least recently used go first).
TABLES_KEPT = 16
#: The environment variable naming the tables' directory on disk (``off``: none).
CACHE_VARIABLE = "LIGHTSAIL_GYM_CACHE"
#: Values of :data:`CACHE_VARIABLE` that keep the tables in memory only.
OFF = ("", "off", "0", "false", "no", "none")
#: Environment variables that choose OpenBLAS's kernels, and with them the tables' last bits.
BLAS_VARIABLES = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")

Table = TypeVar("Table")


def built_once(factory: Callable[..., Table]) -> Callable[..., Table]:
    """``factory`` (positional, hashable arguments with exact ``repr``) called once per distinct arguments
    and machine set-up; its result shared, read-only, and kept on disk for later processes."""

    @functools.lru_cache(maxsize=TABLES_KEPT)
    @functools.wraps(factory)
    def once(*args: object) -> Table:
        table = _stored(factory, args)
        _make_read_only(table)
        return table

    return once


def cache_dir() -> Path | None:
    """Where tables are kept on disk (:data:`CACHE_VARIABLE`), or None."""
    named = os.environ.get(CACHE_VARIABLE)
    if named is not None:
        return None if named.strip().lower() in OFF else Path(named)
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]) / "lightsail-gym"
    try:
        return Path.home() / ".cache" / "lightsail-gym"
    except RuntimeError:  # no home directory to be found: memory only
        return None


def _source_digest() -> str:
    """A digest of ``sail_env/physics`` and ``sail_env/jit.py`` as this process imports them."""
    package = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for path in sorted([*package.joinpath("physics").rglob("*.py"), package / "jit.py"]):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


# Read once, as the package is imported (~1 ms): a process whose sources are edited or checked out
# while it runs goes on filing its tables under the code it runs, not under the files' new state.
_SOURCES = _source_digest()


@functools.cache
def code_version() -> str:
    """A digest of what a table's numbers depend on besides its arguments: the sources
    (:func:`_source_digest`, at import), the versions of Python, NumPy, SciPy and Numba, whether Numba
    compiles, the CPU (its model and the features NumPy's kernels use) and each BLAS library's version
    and kernel (with :data:`BLAS_VARIABLES`, which choose them)."""
    import numba
    import scipy

    from sail_env.physics.blas import blas_libraries
    from sail_env.provenance import cpu_model

    # Sorted: threadpoolctl lists the libraries in the order it finds them, NumPy's and SciPy's OpenBLAS either
    # way round between identical processes, and each order would file the same tables under another key.
    blas = sorted(f"{lib.internal_api} {lib.version} {lib.architecture}" for lib in blas_libraries())
    settings = [_SOURCES, sys.version, np.__version__, scipy.__version__, numba.__version__,
                f"NUMBA_DISABLE_JIT={os.environ.get('NUMBA_DISABLE_JIT')}", platform.machine(), cpu_model(),
                _numpy_cpu_features(), *blas, *(f"{name}={os.environ.get(name)}" for name in BLAS_VARIABLES)]
    return hashlib.sha256("\n".join(settings).encode()).hexdigest()


def _numpy_cpu_features() -> str:
    """The CPU features NumPy's own kernels dispatch on (its transcendental functions round by them)."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:  # NumPy < 2
        from numpy.core._multiarray_umath import __cpu_features__ as features
    return ",".join(sorted(name for name, enabled in features.items() if enabled))


def _stored(factory: Callable[..., Table], args: tuple) -> Table:
    """The table of ``factory(*args)`` from disk, or built (and written there)."""
    directory = cache_dir()
    if directory is None:
        return factory(*args)
    key = hashlib.sha256(f"{factory.__module__}.{factory.__qualname__}{args!r}{code_version()}".encode()).hexdigest()
    path = directory / f"{factory.__qualname__}-{key[:32]}.pkl"
    try:
        with path.open("rb") as file:
            stored_key, table = pickle.load(file)
        loaded = stored_key == key
    except Exception:  # missing, truncated or from another layout: build it again
        loaded = False
    if loaded:
        try:
            os.utime(path)  # recently used: kept by _prune
        except OSError:  # another user's file, a read-only cache, or pruned meanwhile: the table stands
            pass
        return table
    table = factory(*args)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=directory, suffix=".tmp")
    except OSError:
        return table  # a directory that cannot be written: memory only
    try:
        with os.fdopen(handle, "wb") as file:
            pickle.dump((key, table), file, protocol=pickle.HIGHEST_PROTOCOL)
        os.chmod(temporary, 0o644)  # readable by the other users of a shared cache (mkstemp's is 0600)
        os.replace(temporary, path)  # atomic: a reader sees the whole file or none
        _prune(directory, factory.__qualname__)
    except Exception:  # a full disk, or a table that does not pickle: kept in memory only
        pass
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return table


def _prune(directory: Path, name: str) -> None:
    """Keep the :data:`TABLES_KEPT` most recently used files of one kind of table (each change of the
    code writes new ones, and the old are never read again), and remove what writers killed midway
    left (temporary files over an hour old)."""
    files = sorted(directory.glob(f"{name}-*.pkl"), key=lambda path: path.stat().st_mtime, reverse=True)
    for path in files[TABLES_KEPT:]:
        path.unlink(missing_ok=True)
    stale = time.time() - 3600.0
    for path in directory.glob("*.tmp"):
        if path.stat().st_mtime < stale:
            path.unlink(missing_ok=True)


def _make_read_only(value: object, seen: set[int] | None = None) -> None:
    """Mark every NumPy array in ``value`` read-only: the arrays themselves, in lists and tuples, and in
    the attributes of this package's objects (a table's rows, a flight's table) and of SciPy's splines,
    each object once."""
    seen = set() if seen is None else seen
    if id(value) in seen:
        return
    seen.add(id(value))
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, (list, tuple)) and not (value and isinstance(value[0], (float, int))):  # numbers: none
        for item in value:
            _make_read_only(item, seen)
    elif type(value).__module__.startswith(("sail_env.", "scipy.interpolate")):
        slots = [name for kind in type(value).__mro__ for name in getattr(kind, "__slots__", ())]
        for item in [*getattr(value, "__dict__", {}).values(), *(getattr(value, name, None) for name in slots)]:
            _make_read_only(item, seen)
