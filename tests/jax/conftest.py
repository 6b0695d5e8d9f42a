"""The JAX backend's tests: skipped without JAX (``pip install -e ".[jax]"``).

XLA on a CPU contracts multiply-adds and replaces divisions by reciprocals unless told not to; with
these flags (set before JAX starts) the backend's arithmetic is the Numba core's operation for
operation, and the cross-backend tests compare observations to the bit.
"""

import os

EXACT_FLAGS = "--xla_cpu_max_isa=AVX --xla_disable_hlo_passes=algsimp"
if "jax" not in __import__("sys").modules:
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {EXACT_FLAGS}".strip()
