"""One BLAS thread for the plant's small matrix work (docs/physics.md §3, "BLAS threads").

The plant's matrices are small (8×8 models, 45×45 moment generators, stacks of them over a
batch of environments), too small for a BLAS library's threads to pay: OpenBLAS threads a
product once ``M N K`` passes ~65,000 flop, which a 45×45 product does, and on a machine whose
cores are shared (two here, one busy with another job) the threads wait for each other. Measured
with this machine's default of two OpenBLAS threads: a 64-environment batch's last step (its
coast) took 33–54 s against 2.2–3.5 s with one thread. Nothing limits the threads when the env is
used directly (training scripts may call ``threadpool_limits(1)`` themselves; a user need not).

:func:`one_blas_thread` limits every BLAS library loaded in the process (numpy's and scipy's
OpenBLAS are two) to one thread for the duration of a call and restores the caller's setting
afterwards, so the rest of the user's process keeps its threads. It calls the libraries'
``get/set_num_threads`` directly through :mod:`threadpoolctl`'s controllers, found once: ~2 µs a
call, against ~340 µs for entering ``threadpoolctl.threadpool_limits`` (which scans the loaded
libraries every time) and ~12 µs for a prebuilt controller's ``limit`` (measured here), so it can
wrap every coast, parameter build and batched step.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterator
from typing import TypeVar

import scipy.linalg  # noqa: F401  (loads scipy's own BLAS before the libraries are listed)
from threadpoolctl import ThreadpoolController

F = TypeVar("F", bound=Callable)


@functools.lru_cache(maxsize=1)
def blas_libraries() -> tuple:
    """The BLAS libraries of this process (threadpoolctl's controllers), listed once."""
    return tuple(lib for lib in ThreadpoolController().lib_controllers if lib.user_api == "blas")


def blas_threads() -> list[int]:
    """The thread count of each BLAS library in the process (for tests and diagnostics)."""
    return [lib.get_num_threads() for lib in blas_libraries()]


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the block with every BLAS library at one thread; restore each one's count after."""
    changed = []
    for lib in blas_libraries():
        count = lib.get_num_threads()
        if count != 1:
            lib.set_num_threads(1)
            changed.append((lib, count))
    try:
        yield
    finally:
        for lib, count in changed:
            lib.set_num_threads(count)


def single_threaded(function: F) -> F:
    """Decorator: :func:`one_blas_thread` around every call of ``function``."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with one_blas_thread():
            return function(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
