"""Tables built once: per process, and across processes on disk.

Building a 3D realistic task integrates flights and runs surface quadratures: ~0.75 s for
``LightSail3DRealistic-v1``, ~1.1 s more for ``LightSailUncertain-v1``'s curvature table. Every
``gym.make`` of the same task needs the same tables: the envs of a vector, an evaluation, a benchmark
grid's cells, every worker of a ``SubprocVecEnv``, every new process. :func:`built_once` keeps what a
factory built for each distinct tuple of arguments (frozen configurations and numbers, hashable and
compared by value) and hands out the same object, its arrays made read-only, so that no plant can
change another's tables.

It also stores each table on disk (a pickle, written atomically) and loads it in later processes:
the file name is a digest of the factory, its arguments' ``repr`` and :func:`code_version` (this
package's physics sources, NumPy's and SciPy's versions, the CPU and the OpenBLAS settings that choose
its kernels, which round differently), so a change to any of them builds afresh. A loaded table is
the built one to the bit. ``LIGHTSAIL_GYM_CACHE`` names the directory (default
``$XDG_CACHE_HOME/lightsail-gym``, else ``~/.cache/lightsail-gym``); ``off`` keeps tables in memory
only. A directory that cannot be written, or a table that cannot be stored, is kept in memory only; a
file that cannot be read is built again. Of each kind of table the :data:`TABLES_KEPT` most recently
used files are kept (0.03–2 MB each), the older removed. The
files are pickles, as Numba's cache is: a directory others can write is not one to load from.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
import platform
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np

#: How many distinct tables of one kind a process keeps, and the disk (the least recently used go first).
TABLES_KEPT = 16
#: The environment variable naming the tables' directory on disk (``off``: none).
CACHE_VARIABLE = "LIGHTSAIL_GYM_CACHE"
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
        return None if named.strip().lower() in ("", "off") else Path(named)
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]) / "lightsail-gym"
    try:
        return Path.home() / ".cache" / "lightsail-gym"
    except RuntimeError:  # no home directory to be found: memory only
        return None


@functools.cache
def code_version() -> str:
    """A digest of what a table's numbers depend on besides its arguments: the sources of
    ``sail_env/physics`` and ``sail_env/jit.py``, NumPy's and SciPy's versions, the CPU and
    :data:`BLAS_VARIABLES`."""
    import scipy

    package = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for path in sorted([*package.joinpath("physics").rglob("*.py"), package / "jit.py"]):
        digest.update(path.relative_to(package).as_posix().encode())
        digest.update(path.read_bytes())
    settings = [np.__version__, scipy.__version__, platform.machine(), _cpu_model(),
                *(f"{name}={os.environ.get(name)}" for name in BLAS_VARIABLES)]
    digest.update("\n".join(settings).encode())
    return digest.hexdigest()


def _cpu_model() -> str:
    """The CPU's model name (OpenBLAS picks its kernels by it), or the platform's word for it."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def _stored(factory: Callable[..., Table], args: tuple) -> Table:
    """The table of ``factory(*args)`` from disk, or built (and written there)."""
    directory = cache_dir()
    if directory is None:
        return factory(*args)
    key = hashlib.sha256(f"{factory.__module__}.{factory.__qualname__}{args!r}{code_version()}".encode())
    path = directory / f"{factory.__qualname__}-{key.hexdigest()[:32]}.pkl"
    try:
        with path.open("rb") as file:
            table = pickle.load(file)
        os.utime(path)  # recently used: kept by _prune
        return table
    except Exception:  # missing, truncated or from another layout: build it again
        pass
    table = factory(*args)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=directory, suffix=".tmp")
    except OSError:
        return table  # a directory that cannot be written: memory only
    try:
        with os.fdopen(handle, "wb") as file:
            pickle.dump(table, file, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(temporary, path)  # atomic: a reader sees the whole file or none
        _prune(directory, factory.__qualname__)
    except Exception:  # a full disk, or a table that does not pickle: kept in memory only
        pass
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return table


def _prune(directory: Path, name: str) -> None:
    """Keep the :data:`TABLES_KEPT` most recently used files of one kind of table: each change of the
    code writes new ones, and the old are never read again."""
    files = sorted(directory.glob(f"{name}-*.pkl"), key=lambda path: path.stat().st_mtime, reverse=True)
    for path in files[TABLES_KEPT:]:
        path.unlink(missing_ok=True)


def _make_read_only(value: object, seen: set[int] | None = None) -> None:
    """Mark every NumPy array in ``value`` read-only: the arrays themselves, in lists and tuples, and in
    the attributes of this package's objects (a table's rows, a flight's table), each object once."""
    seen = set() if seen is None else seen
    if id(value) in seen:
        return
    seen.add(id(value))
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, (list, tuple)) and not (value and isinstance(value[0], (float, int))):  # numbers: none
        for item in value:
            _make_read_only(item, seen)
    elif type(value).__module__.startswith("sail_env.") and hasattr(value, "__dict__"):
        for item in vars(value).values():
            _make_read_only(item, seen)
