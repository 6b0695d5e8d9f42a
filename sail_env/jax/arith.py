"""The episode core's arithmetic in JAX, operation for operation as the compiled step does it.

Bit-equal results need the same operations in the same order: each dot product is a chain of
multiply-adds from ``0.0`` over the columns in order (:func:`ordered_dot`), ``log10`` is the
project's arithmetic one (:func:`sail_env.core.reward.log10`), not XLA's, and a division stays a
division (:func:`divide`: XLA's algebraic simplifier turns ``x / constant`` into ``x * (1 /
constant)``, which rounds differently). On a CPU, XLA must also be kept from fusing multiply-adds
(``XLA_FLAGS=--xla_cpu_max_isa=AVX``: no FMA instructions); without that flag the results agree to
~1e-15 relative. (Disabling the simplifier instead, ``--xla_disable_hlo_passes=algsimp``, makes
jaxlib 0.10's CPU compiler crash in 2-6 of 10 processes compiling these functions, measured.)
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from sail_env.core import reward as numba_reward

_SIGN_EXPONENT_MASK = 0x7FF
_MANTISSA_BITS = 0x000FFFFFFFFFFFFF
_EXPONENT_OF_ONE = 0x3FF0000000000000


def divide(numerator: jax.Array, denominator: jax.Array | float) -> jax.Array:
    """``numerator / denominator`` as a true division. XLA's simplifier turns a division by a
    broadcast value (a scalar param, a constant, anything ``vmap`` shares across environments)
    into a product with its reciprocal, which rounds differently; an optimisation barrier hides the
    denominator, given the numerator's full (batched) shape first: an integer OR with the
    numerator's bits ANDed with 0 makes it depend on the numerator, so ``vmap`` batches it too."""
    numerator = jnp.asarray(numerator)
    bits = jnp.int64 if numerator.dtype == jnp.float64 else jnp.int32
    shaped = jnp.broadcast_to(jnp.asarray(denominator, numerator.dtype), numerator.shape)
    tied = jax.lax.bitcast_convert_type(shaped, bits) | (jax.lax.bitcast_convert_type(numerator, bits) & 0)
    numerator, hidden = jax.lax.optimization_barrier((numerator, jax.lax.bitcast_convert_type(tied, numerator.dtype)))
    return numerator / hidden


def ordered_dot(matrix: jax.Array, vector: jax.Array) -> jax.Array:
    """``matrix @ vector`` (r, c) × (c,) as the kernels sum it: from 0.0 over the columns in order."""
    total = jnp.zeros(matrix.shape[:-1], dtype=matrix.dtype)
    for k in range(matrix.shape[-1]):
        total = total + matrix[..., k] * vector[k]
    return total


def log10(x: jax.Array) -> jax.Array:
    """:func:`sail_env.core.reward.log10` (float64): the exponent from the bits, the mantissa's
    logarithm by its atanh series, the same constants and order."""
    bits = jax.lax.bitcast_convert_type(x, jnp.int64)
    exponent = ((bits >> 52) & _SIGN_EXPONENT_MASK) - 1023
    mantissa = jax.lax.bitcast_convert_type((bits & _MANTISSA_BITS) | _EXPONENT_OF_ONE, jnp.float64)
    above = mantissa > numba_reward._SQRT2
    mantissa = jnp.where(above, 0.5 * mantissa, mantissa)
    exponent = (exponent + above).astype(jnp.float64)
    s = (mantissa - 1.0) / (mantissa + 1.0)
    z = s * s
    terms = numba_reward._ATANH_TERMS
    series = jnp.full_like(s, terms[8])
    for k in range(7, -1, -1):
        series = terms[k] + z * series
    ln_mantissa = 2.0 * s + 2.0 * s * z * series
    return exponent * numba_reward._LOG10_2_HIGH + (exponent * numba_reward._LOG10_2_LOW
                                                   + ln_mantissa * numba_reward._LOG10_E)


def log_ratio(pointing: jax.Array) -> jax.Array:
    """:func:`sail_env.core.reward.log_ratio_of`: ``log10(pointing / tolerance)`` clipped. In float32
    (the backend's fast option, not the Numba core's arithmetic) XLA's ``log10``."""
    low, high = numba_reward.LOG_RATIO_RANGE
    if pointing.dtype != jnp.float64:
        smallest = jnp.finfo(pointing.dtype).tiny
        return jnp.clip(jnp.log10(jnp.maximum(pointing / numba_reward._TOLERANCE, smallest)), low, high)
    ratio = log10(divide(jnp.maximum(pointing, 1e-300), numba_reward._TOLERANCE))
    return jnp.minimum(jnp.maximum(ratio, low), high)
