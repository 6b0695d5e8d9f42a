"""Tables built once: per process, and across processes on disk.

Building a 3D realistic task integrates flights and runs surface quadratures: ~0.75 s for
``LightSail3DRealistic-v1``, ~1.1 s more for ``LightSailUncertain-v1``'s curvature table, ~12 s more
for ``LightSailUncertain-v2``'s curvature table over the widened spot. Every
``gym.make`` of the same task needs the same tables: the envs of a vector, an evaluation, a benchmark
grid's cells, every worker of a ``SubprocVecEnv``, every new process. :func:`built_once` keeps what a
factory built for each distinct tuple of arguments (frozen configurations and numbers, hashable and
compared by value) and hands out the same object, its arrays made read-only, so that no plant can
change another's tables.

It also stores each table on disk and loads it in later processes: the key is a digest of the factory,
its arguments' ``repr`` and :func:`code_version` (this package's physics sources as the process imported
them, the versions of Python, NumPy, SciPy and Numba, the CPU and the features NumPy dispatches on, each
BLAS library's version and kernel, sorted), so a change to any of them builds afresh. A file holds a
first line naming the format and its version, a line of the key and the SHA-256 of the rest, and an
``.npz`` archive of the table's arrays (read without pickle) and its structure as JSON (its objects'
classes and functions named, of this package and SciPy only, none of them called by loading:
:func:`_to_arrays`). A file that is truncated, damaged, of another format or version or holds another
key is never used: the table is built again, with one warning, and the file replaced. Files are written
to a temporary file and renamed (a reader sees a whole file or none; two processes writing the same table
leave one), readable by all. A loaded table is the built one to the bit. ``LIGHTSAIL_GYM_CACHE`` names
the directory (default ``$XDG_CACHE_HOME/lightsail-gym``, else ``~/.cache/lightsail-gym``); ``off`` (or
``0``, ``false``, ``no``, ``none``, empty) keeps tables in memory only. A directory that cannot be
written, or a table the format cannot hold, is kept in memory only. Of each kind of table the
:data:`TABLES_KEPT` most recently used files are kept (0.03–2 MB each), the older removed. A file can
still name a function of this package or SciPy for a table to call later: a directory others can write
is not one to load from. Every array is read-only, the splines' coefficients included; the tables' few
Python lists are not, and nothing writes to them.
"""

from __future__ import annotations

import copyreg
import functools
import hashlib
import importlib
import io
import json
import os
import pickle
import platform
import sys
import tempfile
import time
import types
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO, TypeVar

import numpy as np

#: How many distinct tables of one kind a process keeps, and the disk (the least recently used go first).
TABLES_KEPT = 16
#: The environment variable naming the tables' directory on disk (``off``: none).
CACHE_VARIABLE = "LIGHTSAIL_GYM_CACHE"
#: Values of :data:`CACHE_VARIABLE` that keep the tables in memory only.
OFF = ("", "off", "0", "false", "no", "none")
#: Environment variables that choose OpenBLAS's kernels, and with them the tables' last bits.
BLAS_VARIABLES = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")
#: The first line of every table file: its format and the format's version (a file without it is not read).
FORMAT = b"lightsail-gym table 1\n"
#: The table files' suffix.
SUFFIX = ".table"
#: The packages whose classes and functions a table file may name (by module and qualified name).
NAMED_FROM = ("sail_env.", "scipy.")

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
    """The table of ``factory(*args)`` from disk, or built (and written there). A file that is there but
    fails a check (:func:`_read`) is built again with one warning, and replaced."""
    directory = cache_dir()
    if directory is None:
        return factory(*args)
    key = hashlib.sha256(f"{factory.__module__}.{factory.__qualname__}{args!r}{code_version()}".encode()).hexdigest()
    path = directory / f"{factory.__qualname__}-{key[:32]}{SUFFIX}"
    try:
        stored_key, table = _read(path)
        if stored_key != key:
            raise ValueError(f"it holds another table (key {stored_key[:16]}…)")
    except (FileNotFoundError, NotADirectoryError):  # not there: built
        pass
    except Exception as error:  # truncated, damaged, foreign or unreadable: never used
        warnings.warn(f"table cache: {path} not used ({error}); built again and replaced", RuntimeWarning,
                      stacklevel=3)
    else:
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
            _write(file, key, table)
        os.chmod(temporary, 0o644)  # readable by the other users of a shared cache (mkstemp's is 0600)
        os.replace(temporary, path)  # atomic: a reader sees the whole file or none
        _prune(directory, factory.__qualname__)
    except Exception:  # a full disk, or a table this format cannot hold: kept in memory only
        pass
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
    return table


def _write(file: BinaryIO, key: str, table: object) -> None:
    """``table`` and its key in the cache's format: the line :data:`FORMAT`, a line ``KEY SHA256`` (the
    SHA-256 of what follows) and an ``.npz`` archive of the table's arrays and its structure
    (:func:`_to_arrays`, as JSON)."""
    structure, arrays = _to_arrays(table)
    payload = io.BytesIO()
    np.savez(payload, structure=np.frombuffer(json.dumps(structure).encode(), np.uint8),
             **{str(i): array for i, array in enumerate(arrays)})
    file.write(FORMAT + f"{key} {hashlib.sha256(payload.getvalue()).hexdigest()}\n".encode() + payload.getvalue())


def _read(path: Path) -> tuple[str, object]:
    """``(key, table)`` of a file :func:`_write` wrote; ValueError if it is of another format or version, or
    its content is not the one its digest was taken of (truncated, bits flipped). Nothing in it is
    executed: its arrays are read without pickle, and its objects are made by :func:`_from_arrays`."""
    content = path.read_bytes()
    if not content.startswith(FORMAT):
        raise ValueError("not a table file of this format and version")
    line, _, payload = content[len(FORMAT):].partition(b"\n")
    key, _, digest = line.decode("ascii", "replace").partition(" ")
    if hashlib.sha256(payload).hexdigest() != digest:
        raise ValueError("its content does not match its SHA-256 (truncated or damaged)")
    with np.load(io.BytesIO(payload), allow_pickle=False) as archive:
        structure = json.loads(archive["structure"].tobytes())
        return key, _from_arrays(structure, [archive[str(i)] for i in range(len(archive.files) - 1)])


def _to_arrays(table: object) -> tuple[object, list[np.ndarray]]:
    """``table`` as a JSON structure and the arrays it refers to by number: numbers, strings and None as
    themselves; NumPy arrays and scalars (not of objects), lists, tuples, dicts, ``functools.partial``
    objects, and the functions and the objects of classes of :data:`NAMED_FROM` (by name; an object's
    state as pickle would take it) as one-key dicts. An array, list, dict or object met again is a reference (``{"ref": n}``,
    numbered as first met), so shared parts stay shared. Anything else: an error (not stored)."""
    arrays: list[np.ndarray] = []
    numbered: dict[int, tuple[int, object]] = {}  # id -> (number, the value, kept alive while its id is used)

    def number(value: object) -> None:
        numbered[id(value)] = (len(numbered), value)

    def encode(value: object) -> object:
        if value is None or type(value) in (bool, int, float, str):
            return value
        if id(value) in numbered:
            return {"ref": numbered[id(value)][0]}
        if type(value) is tuple:
            return {"tuple": [encode(item) for item in value]}
        if isinstance(value, (np.ndarray, np.generic)) and not value.dtype.hasobject:
            number(value)
            arrays.append(np.asarray(value))
            return {"array" if isinstance(value, np.ndarray) else "scalar": len(arrays) - 1}
        if type(value) in (list, dict):
            number(value)
            if type(value) is list:
                return {"list": [encode(item) for item in value]}
            return {"dict": [[encode(k), encode(v)] for k, v in value.items()]}
        if type(value) is functools.partial:
            encoded = {"partial": [encode(value.func), encode(value.args), encode(value.keywords)]}
            number(value)
            return encoded
        name = _name_of(value if isinstance(value, types.FunctionType) else type(value))
        if isinstance(value, types.FunctionType):
            return {"function": name}
        reduced = value.__reduce_ex__(pickle.HIGHEST_PROTOCOL)
        if not (reduced[:2] == (copyreg.__newobj__, (type(value),)) and all(x is None for x in reduced[3:])):
            raise TypeError(f"{name} is not made by __new__ and its state")
        number(value)
        return {"object": [name, encode(reduced[2] if len(reduced) > 2 else None)]}

    return encode(table), arrays


def _from_arrays(structure: object, arrays: list[np.ndarray]) -> object:
    """The table :func:`_to_arrays` took apart. It creates instances of named classes with ``__new__`` and
    gives them their state as pickle does (``__setstate__``, else their ``__dict__`` and slots); it calls
    none of the functions it names."""
    numbered: list[object] = []

    def decode(item: object) -> object:
        if not isinstance(item, dict):
            if isinstance(item, list):
                raise ValueError("a bare list in the structure")
            return item
        ((kind, content),) = item.items()
        if kind == "ref":
            return numbered[content]
        if kind == "tuple":
            return tuple(decode(x) for x in content)
        if kind in ("array", "scalar"):
            value = arrays[content] if kind == "array" else arrays[content][()]
            numbered.append(value)
            return value
        if kind in ("list", "dict"):
            made: list | dict = [] if kind == "list" else {}
            numbered.append(made)
            if isinstance(made, list):
                made.extend(decode(x) for x in content)
            else:
                made.update((decode(k), decode(v)) for k, v in content)
            return made
        if kind == "partial":
            function, partial_args, keywords = (decode(x) for x in content)
            made = functools.partial(function, *partial_args, **keywords)
            numbered.append(made)
            return made
        if kind == "function":
            return _named(content, types.FunctionType)
        if kind != "object":
            raise ValueError(f"an unknown kind {kind!r} in the structure")
        name, state = content
        cls = _named(name, type)
        made = cls.__new__(cls)
        numbered.append(made)
        state = decode(state)
        if hasattr(made, "__setstate__"):
            made.__setstate__(state)
            return made
        state, slots = state if isinstance(state, tuple) else (state, None)
        if state:
            vars(made).update(state)
        for slot, value in (slots or {}).items():
            setattr(made, slot, value)
        return made

    return decode(structure)


def _name_of(value: type | types.FunctionType) -> str:
    """``module:qualname`` of a class or function of :data:`NAMED_FROM` that is found again by that name;
    else an error (the table is not stored)."""
    name = f"{value.__module__}:{value.__qualname__}"
    if _named(name, type(value) if isinstance(value, types.FunctionType) else type) is not value:
        raise TypeError(f"{name} is not found by its name")
    return name


def _named(name: str, kind: type) -> object:
    """The class or function ``module:qualname`` of a module of :data:`NAMED_FROM` (imported if need be: a
    new process that loads a table may not have imported its classes' modules yet), if it is a ``kind``;
    else ValueError."""
    module_name, _, qualname = name.partition(":")
    if not module_name.startswith(NAMED_FROM):
        raise ValueError(f"{name} is not of a module of {', '.join(NAMED_FROM)}")
    value = functools.reduce(getattr, qualname.split("."), importlib.import_module(module_name))
    if not isinstance(value, kind):
        raise ValueError(f"{name} is not a {kind.__name__}")
    return value


def _prune(directory: Path, name: str) -> None:
    """Keep the :data:`TABLES_KEPT` most recently used files of one kind of table (each change of the
    code writes new ones, and the old are never read again; the pickles of the format before
    :data:`FORMAT` count too), and remove what writers killed midway left (temporary files over an
    hour old)."""
    files = sorted(directory.glob(f"{name}-*"), key=lambda path: path.stat().st_mtime, reverse=True)
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
