"""The reward and the success rule: one definition each, used by the compiled step and the scoring.

With ``ρ(p) = clip(log10(p / tolerance), -2, 3)`` each step earns ``-ρ(envelope) / N``; the last
adds ``-ρ(pointing at cut-off)`` and :data:`SUCCESS_BONUS` on success (:func:`succeeded`);
a divergence replaces the step's reward by :data:`DIVERGENCE_PENALTY`.

The logarithm is :func:`log10`, arithmetic only (no library call), so that the compiled step computes
a block of environments' rewards in one vectorised loop: the C library's ``log10`` cost ~20 of the
~110 ns of a ``LightSail-v0`` step at N = 1024 (2026-12-03, one-off). It agrees with
``math.log10`` to two units in the last place of the result (4.4e-16 where the reward keeps the
ratio, 0.01 … 1000; 96.5 % of uniform draws there to the bit), the same on every machine.
"""

from __future__ import annotations

import decimal
import math

import numpy as np

from sail_env.jit import compiled, inlined
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD

# Numba's cache follows this file alone: the line below (tests/test_numba_cache.py) changes it when
# a file whose code or constants its compiled functions take in changes, so that they compile again.
# compiled in: sail_env/jit.py sail_env/physics/pointing.py sha256:0336275251e9904a

#: Reward: log10 of (pointing / tolerance) is clipped to this range.
LOG_RATIO_RANGE = (-2.0, 3.0)
SUCCESS_BONUS = 1.0
DIVERGENCE_PENALTY = -10.0
_LOW, _HIGH = LOG_RATIO_RANGE
_TOLERANCE = POINTING_TOLERANCE_RAD

# log10(x) = e log10(2) + log10(e) · ln m for x = 2^e m, m in [√½, √2); ln m = 2 atanh(s) =
# 2 (s + s³/3 + s⁵/5 + …) with s = (m - 1)/(m + 1), |s| ≤ 0.1716: the nine terms after s leave
# s^20/21 < 3e-17 of it (eight left 1.3e-16 in the result). log10(2) is split so that e times its
# leading part is exact.
_MANTISSA_BITS, _EXPONENT_OF_ONE = 0x000FFFFFFFFFFFFF, 0x3FF0000000000000
_SQRT2 = math.sqrt(2.0)
_LOG10_2_HIGH = float(np.int64(np.float64(math.log10(2.0)).view(np.int64) & ~0xFFFFFFF).view(np.float64))
with decimal.localcontext(decimal.Context(prec=40)):  # correctly rounded (1 / math.log(10) is an ulp low)
    _LOG10_E = float(1 / decimal.Decimal(10).ln())
    _LOG10_2_LOW = float(decimal.Decimal(2).log10() - decimal.Decimal(_LOG10_2_HIGH))
_ATANH_TERMS = tuple(1.0 / (2 * k + 1) for k in range(1, 10))  # 1/3, 1/5, …, 1/19


@inlined
def log10(x: float) -> float:
    """``log10(x)`` of a positive normal number by arithmetic alone (+inf gives 308.25, above any
    clip; zero, subnormals, negatives and NaN are not its inputs)."""
    bits = np.float64(x).view(np.int64)
    exponent = ((bits >> 52) & 0x7FF) - 1023
    mantissa = np.int64((bits & _MANTISSA_BITS) | _EXPONENT_OF_ONE).view(np.float64)  # in [1, 2)
    above = mantissa > _SQRT2
    mantissa = 0.5 * mantissa if above else mantissa
    exponent = exponent + 1 if above else exponent
    s = (mantissa - 1.0) / (mantissa + 1.0)
    z = s * s
    series = _ATANH_TERMS[8]
    for k in range(7, -1, -1):
        series = _ATANH_TERMS[k] + z * series
    ln_mantissa = 2.0 * s + 2.0 * s * z * series
    return exponent * _LOG10_2_HIGH + (exponent * _LOG10_2_LOW + ln_mantissa * _LOG10_E)


@inlined
def log_ratio_of(pointing: float) -> float:
    """``log10(pointing / tolerance)`` clipped to :data:`LOG_RATIO_RANGE` (zero pointing: the low end)."""
    ratio = log10(max(pointing, 1e-300) / _TOLERANCE)
    return min(max(ratio, _LOW), _HIGH)


@compiled
def log_ratio(pointing: np.ndarray) -> np.ndarray:
    """:func:`log_ratio_of` of each pointing (k,) [rad] (NaN stays NaN)."""
    out = np.empty(pointing.shape[0])
    for i in range(pointing.shape[0]):
        out[i] = log_ratio_of(pointing[i]) if pointing[i] == pointing[i] else np.nan
    return out


def succeeded(pointing_rad: np.ndarray) -> np.ndarray:
    """Whether each flight at cut-off points within the tolerance (inf for a divergence, NaN for an
    episode still running: both fail). The only place success is decided, for both backends: an
    array (NumPy's, or JAX's under ``jit``) is compared as it is, anything else as a NumPy array."""
    pointing = pointing_rad if hasattr(pointing_rad, "dtype") else np.asarray(pointing_rad)
    return pointing <= POINTING_TOLERANCE_RAD
