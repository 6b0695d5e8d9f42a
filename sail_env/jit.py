"""The one place the compiled functions get their compiler options: the episode core's kernels
and the 3D flight's push law and Runge–Kutta step (arithmetic only, so compiled they give Python's
numbers to the last bit).

``error_model="numpy"``: a division by zero gives inf/NaN as in NumPy instead of a check and a
branch on every division (which also stops LLVM from vectorising the loops). ``cache=True``: the
machine code is written beside the source (``__pycache__``), so only the first import after a
change compiles (seconds); later processes load it (a fraction of a second). With
``NUMBA_DISABLE_JIT=1`` the same functions run as plain Python, which is how coverage and
mutation tools see the kernels' logic
(``tests/core/test_compiled_core.py::test_the_kernels_logic_runs_as_python_with_the_same_results``).
"""

from __future__ import annotations

import warnings

import numba
from numba.core.cpu import CPUTargetOptions

#: The decorator of every compiled function of the core.
compiled = numba.njit(cache=True, error_model="numpy", nogil=True)

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
kernel = numba.njit(cache=True, error_model="numpy", nogil=True, **_NO_REFERENCE_COUNTING)

#: For the kernels' one-line index helpers: inlined into each caller before typing. Compiled as
#: functions, each call with another constant argument (a field's slot) was typed as its own
#: literal and compiled again: twelve times for one helper, six for the other, ~0.5 s of the step's
#: first compile.
inlined = numba.njit(inline="always", error_model="numpy", nogil=True, **_NO_REFERENCE_COUNTING)
