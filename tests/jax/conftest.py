"""The JAX backend's tests: skipped without JAX (``pip install -e ".[jax]"``).

XLA on a CPU fuses multiply-adds unless told not to (:mod:`sail_env.jax.arith`); with this flag (set
before JAX starts) the backend's arithmetic is the Numba core's operation for operation, and the
cross-backend tests compare observations to the bit.
"""

import os

EXACT_FLAGS = "--xla_cpu_max_isa=AVX"
if "jax" not in __import__("sys").modules:
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {EXACT_FLAGS}".strip()
