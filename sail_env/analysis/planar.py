"""Questions asked of one planar model, off the runtime path: the beam jitter its sail tolerates
(docs/physics.md §3) and its phase-free envelope kept for repeated queries (the paper's figures).
The envs' envelopes come from the plants' own tables (:func:`~sail_env.physics.pointing.envelope_table`)."""

from __future__ import annotations

import numpy as np
import scipy.special

from sail_env.physics.noise import WhiteNoise
from sail_env.physics.planar.model import VX, PlanarModel, propagate_moments, rates
from sail_env.physics.pointing import envelope_table, peak_speed


def tolerable_jitter_psd(model: PlanarModel, duration: float, tolerance_rad: float,
                         cutoff_s: float, probability: float = 0.95) -> float:
    """Largest beam-jitter PSD [m² s] that keeps ``|V⊥|/Vz ≤ tolerance_rad`` at cut-off
    with the given probability, for a sail that is perfectly on the beam ``duration``
    seconds before cut-off and then left to the jitter (docs/physics.md §3).

    The velocity variance is linear in the PSD, so one unit-PSD propagation suffices.
    """
    if not 0 < probability < 1:
        raise ValueError(f"probability must be in (0, 1), got {probability}")
    _, unit_cov = propagate_moments(model, np.zeros(4), np.zeros((4, 4)), np.zeros(2), duration,
                                    WhiteNoise(beam_jitter_psd_m2s=1.0))
    quantile = float(scipy.special.ndtri(0.5 + probability / 2))
    allowed_speed = tolerance_rad * model.equilibrium_speed(cutoff_s) / quantile
    return allowed_speed**2 / unit_cov[1, 1]


class EnvelopeEstimator:
    """The envelope of one model: :func:`envelope_table` kept for repeated queries."""

    def __init__(self, model: PlanarModel, periods: float = 1.0,
                 samples_per_fast_period: int = 32, max_samples: int = 2048) -> None:
        self.table = envelope_table(model.A, model.B, rows=(VX,), mode_rates=rates(model.A), periods=periods,
                                    samples_per_fast_period=samples_per_fast_period, max_samples=max_samples)

    def peak_speed(self, state: np.ndarray, action: np.ndarray) -> float:
        """max over the look-ahead of ``|Vx|`` [m/s], input ``action`` held."""
        return float(peak_speed(self.table, state, action))
