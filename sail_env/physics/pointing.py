"""Terminal pointing: the flight direction at beam cut-off, and its phase-free envelope.

After cut-off nothing pushes the sail, so it flies along its velocity: the pointing
error is ``|V⊥| / Vz`` at ``t_cut`` (the lateral offset, metres, is negligible over
4.25 light-years). The seed paper (its §3.4) scores the sail's tilt θ instead; that is
not the flight direction. Because V⊥ oscillates at ~70 rad/s, the value at cut-off
depends on the cut-off phase, so we also report the *envelope*: the largest
``|V⊥|/Vz`` over a look-ahead with the beam kept on and the input held.
"""

from __future__ import annotations

import math

import numpy as np

from sail_env.physics.planar import VX, PlanarModel, zoh_discretize

#: Seed eq 20: the flight direction must be within ~1e-8 rad to pass Proxima b closer
#: than the Earth-Moon distance (see :func:`sail_env.physics.mission.pointing_tolerance_rad`).
POINTING_TOLERANCE_RAD = 1e-8


def pointing_error(model: PlanarModel, state: np.ndarray, t: float) -> float:
    """``|Vx| / Vz`` [rad] for a state at flight time ``t`` (beam cut off then)."""
    return abs(float(state[VX])) / model.equilibrium_speed(t)


class EnvelopeEstimator:
    """Largest future ``|Vx|`` with the input held, from precomputed propagators.

    The look-ahead spans ``periods`` of the slowest beat between oscillation modes (at
    least ``periods`` of the slowest mode) sampled at ``samples_per_fast_period`` per
    period of the fastest, so it converges to the sum of the modes' amplitudes. For a
    single mode it is the amplitude of the oscillation, within ``1 − cos(π/n)``.
    """

    def __init__(self, model: PlanarModel, periods: float = 1.0,
                 samples_per_fast_period: int = 32, max_samples: int = 2048) -> None:
        freqs = model.stability.frequencies
        if not freqs:
            # No oscillation: growth or drift shows within a few e-folding times.
            rate = max(model.stability.growth_rate, 1.0)
            horizon, spacing = 5.0 / rate, 5.0 / rate / 64
        else:
            slowest = min(freqs)
            beats = [abs(f1 - f2) for f1 in freqs for f2 in freqs if f1 != f2]
            slowest = min([slowest, *beats])
            horizon = periods * 2 * math.pi / slowest
            spacing = 2 * math.pi / max(freqs) / samples_per_fast_period
        n = min(max_samples, max(2, math.ceil(horizon / spacing) + 1))
        self.times = np.linspace(0.0, horizon, n)
        step_phi, step_gamma = zoh_discretize(model.A, model.B, self.times[1])
        phis, gammas = [np.eye(4)], [np.zeros_like(model.B)]
        for _ in range(n - 1):
            phis.append(step_phi @ phis[-1])
            gammas.append(step_phi @ gammas[-1] + step_gamma)
        # Only the Vx rows are needed: envelope = max_i |phi_i[VX] s + gamma_i[VX] u|.
        self._phi_vx = np.array([p[VX] for p in phis])
        self._gamma_vx = np.array([g[VX] for g in gammas])

    def peak_speed(self, state: np.ndarray, action: np.ndarray) -> float:
        """max over the look-ahead of ``|Vx|`` [m/s], input ``action`` held."""
        return float(np.abs(self._phi_vx @ state + self._gamma_vx @ action).max())
