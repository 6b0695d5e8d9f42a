"""The one place the compiled functions get their compiler options: the episode core's kernels
and the 3D flight's push law and Runge–Kutta step (arithmetic only, so compiled they give Python's
numbers to the last bit).

``error_model="numpy"``: a division by zero gives inf/NaN as in NumPy instead of a check and a
branch on every division (which also stops LLVM from vectorising the loops). ``cache=True``: the
machine code is written beside the source (``__pycache__``), so only the first import after a
change compiles (seconds); later processes load it (a fraction of a second). Where Numba finds no
directory to write it to (a read-only install used without a writable home, and no
``NUMBA_CACHE_DIR``), Numba refuses the function at import; :func:`_cached` compiles it without
a cache instead (in every process), with one warning that says how to keep one. With
``NUMBA_DISABLE_JIT=1`` the same functions run as plain Python, which is how coverage and
mutation tools see the kernels' logic
(``tests/core/test_compiled_core.py::test_the_kernels_logic_runs_as_python_with_the_same_results``).
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable

import numba
from numba.core.cpu import CPUTargetOptions


def _cached(**options: object) -> Callable[[Callable], Callable]:
    """``numba.njit(cache=True, **options)``, or, where Numba has nowhere to cache the function, the same
    without a cache (and :func:`_warn_uncached`)."""

    def decorate(function: Callable) -> Callable:
        try:
            return numba.njit(cache=True, **options)(function)
        except RuntimeError as error:  # Numba's "cannot cache function ...: no locator available for file ..."
            if "no locator available" not in str(error):
                raise
            _warn_uncached()
            return numba.njit(**options)(function)

    return decorate


@functools.cache
def _warn_uncached() -> None:
    """One warning per process, at the first function Numba cannot cache."""
    warnings.warn("Numba has no writable directory to cache sail_env's compiled functions in (beside the sources, "
                  "or in the home directory's cache): they are compiled in every process (seconds); set "
                  "NUMBA_CACHE_DIR to a writable directory to keep them", RuntimeWarning, stacklevel=3)


#: The decorator of every compiled function of the core.
compiled = _cached(error_model="numpy", nogil=True)

#: For the episode core's kernels (:mod:`sail_env.core.kernels`), which allocate nothing (the
#: caller passes every array, scratch included): compiled without Numba's reference counting of
#: arrays (``_nrt=False``, Numba's own switch for code that needs no allocator). With it, an array
#: read in a branch of an inlined helper kept an atomic increment and decrement per environment that
#: Numba's pruning did not remove: the observation of an unwrapped ``LightSail-v0`` cost 66 ns per
#: environment at N = 1024, 14 ns without (2026-12-03, one-off timing); the numbers are the same bits.
#: ``_nrt`` is not in Numba's documented options: a Numba without it gets the counted kernels (the
#: same numbers, slower) and a warning, not an error at the first step.
_NO_REFERENCE_COUNTING = {"_nrt": False} if hasattr(CPUTargetOptions, "_nrt") else {}
if not _NO_REFERENCE_COUNTING:
    warnings.warn(f"numba {numba.__version__} has no _nrt option: the episode core's kernels count references "
                  "(slower, same numbers)", RuntimeWarning, stacklevel=1)
kernel = _cached(error_model="numpy", nogil=True, **_NO_REFERENCE_COUNTING)

#: For the kernels' one-line index helpers: inlined into each caller before typing. Compiled as
#: functions, each call with another constant argument (a field's slot) was typed as its own
#: literal and compiled again: twelve times for one helper, six for the other, ~0.5 s of the step's
#: first compile.
inlined = numba.njit(inline="always", error_model="numpy", nogil=True, **_NO_REFERENCE_COUNTING)
