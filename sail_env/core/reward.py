"""The reward and the success rule: one definition each, used by the compiled step and the scoring.

With ``ρ(p) = clip(log10(p / tolerance), -2, 3)`` each step earns ``-ρ(envelope) / N``; the last
adds ``-ρ(pointing at cut-off)`` and :data:`SUCCESS_BONUS` on success (:func:`succeeded`);
a divergence replaces the step's reward by :data:`DIVERGENCE_PENALTY`.
"""

from __future__ import annotations

import math

import numpy as np

from sail_env.jit import compiled
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD

#: Reward: log10 of (pointing / tolerance) is clipped to this range.
LOG_RATIO_RANGE = (-2.0, 3.0)
SUCCESS_BONUS = 1.0
DIVERGENCE_PENALTY = -10.0
_LOW, _HIGH = LOG_RATIO_RANGE
_TOLERANCE = POINTING_TOLERANCE_RAD


@compiled
def log_ratio_of(pointing: float) -> float:
    """``log10(pointing / tolerance)`` clipped to :data:`LOG_RATIO_RANGE` (zero pointing: the low end)."""
    ratio = math.log10(max(pointing, 1e-300) / _TOLERANCE)
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
    episode still running: both fail). The only place success is decided."""
    return np.asarray(pointing_rad) <= POINTING_TOLERANCE_RAD
