"""Terminal pointing: the flight direction at beam cut-off, and its phase-free envelope.

After cut-off nothing pushes the sail, so it flies along its velocity: the pointing
error is ``|V⊥| / Vz`` at ``t_cut`` (the lateral offset, metres, is negligible over
4.25 light-years). The seed paper (its §3.4) scores the sail's tilt θ instead; that is
not the flight direction. Because V⊥ oscillates at ~70 rad/s, the value at cut-off
depends on the cut-off phase, so we also report the *envelope*: the largest
``|V⊥|/Vz`` over a look-ahead with the beam kept on and the input held.
"""

from __future__ import annotations

import numpy as np

from sail_env.jit import compiled
from sail_env.physics.linear import zoh_discretize
from sail_env.physics.planar import VX, PlanarModel, rates

# Numba's cache follows this file alone: the line below (tests/test_numba_cache.py) changes it when
# a file whose code or constants its compiled functions take in changes, so that they compile again.
# compiled in: sail_env/jit.py sha256:9d3b73adb7f50647

#: Seed eq 20: the flight direction must be within ~1e-8 rad to pass Proxima b closer
#: than the Earth-Moon distance (see :func:`sail_env.physics.mission.pointing_tolerance_rad`).
POINTING_TOLERANCE_RAD = 1e-8
#: Largest growth ``e^MAX_LOOKAHEAD_GROWTH`` of an unstable sail over the envelope's look-ahead: an
#: unstable mode whose beat sets a long look-ahead would overflow the table (a spinning balloon's
#: slow beat, e.g.), and an envelope e^20 above the state already saturates the reward.
MAX_LOOKAHEAD_GROWTH = 20.0


def pointing_error(model: PlanarModel, state: np.ndarray, t: float) -> float:
    """``|Vx| / Vz`` [rad] for a state at flight time ``t`` (beam cut off then)."""
    return abs(float(state[VX])) / model.equilibrium_speed(t)


def envelope_table(a: np.ndarray, b: np.ndarray, periods: float = 1.0, samples_per_fast_period: int = 32,
                   max_samples: int = 2048, rows: tuple[int, ...] = (VX,),
                   mode_rates: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Rows ``[Φ(t_i)[r], Γ(t_i)[r]]`` for each ``r`` in ``rows`` (..., S, R·(n + m)) over the
    look-ahead of each model in a batch (planar: the one row Vx, (..., S, 6)).

    The look-ahead spans ``periods`` of the slowest beat between oscillation modes (at
    least ``periods`` of the slowest mode) sampled at ``samples_per_fast_period`` per
    period of the fastest, so its maximum converges to the sum of the modes' amplitudes;
    for a single mode it is the amplitude within ``1 − cos(π/n)``. A model without
    oscillation looks ahead five e-folding times (at least 5 s); an unstable one at most
    :data:`MAX_LOOKAHEAD_GROWTH` e-folds. Each model gets its own
    number of samples; shorter tables are padded with their last row, which leaves the
    maximum unchanged. ``mode_rates`` is ``(growth (...,), frequencies (..., 2), NaN where
    none)``, by default the planar closed form :func:`~sail_env.physics.planar.rates`.
    """
    growth, freqs = rates(a) if mode_rates is None else mode_rates
    growth, freqs = np.atleast_1d(growth), np.atleast_2d(freqs)
    count = np.sum(~np.isnan(freqs), axis=-1)
    slowest = np.nanmin(np.where(count[:, None] > 0, freqs, np.inf), axis=-1)
    fastest = np.nanmax(np.where(count[:, None] > 0, freqs, -np.inf), axis=-1)
    beat = np.where(count == 2, np.abs(freqs[:, 0] - freqs[:, 1]), np.inf)
    beat = np.where(beat > 0, beat, np.inf)  # equal frequencies beat at no rate
    rate = np.maximum(growth, 1.0)
    oscillating = count > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        horizon = np.where(oscillating, periods * 2 * np.pi / np.minimum(slowest, beat), 5.0 / rate)
        horizon = np.minimum(horizon, np.where(growth > 0, MAX_LOOKAHEAD_GROWTH / growth, np.inf))
        spacing = np.where(oscillating, 2 * np.pi / fastest / samples_per_fast_period, 5.0 / rate / 64)
    samples = np.minimum(max_samples, np.maximum(2, np.ceil(horizon / spacing).astype(np.int64) + 1))
    n, m = b.shape[-2:]
    step_phi, step_gamma = zoh_discretize(a.reshape(-1, n, n), b.reshape(-1, n, m), horizon / (samples - 1))
    k = len(samples)
    table = np.empty((k, samples.max(), len(rows), n + m))
    _fill_envelope(step_phi, step_gamma, samples, np.asarray(rows, dtype=np.int64), table)
    return table.reshape(*a.shape[:-2], samples.max(), len(rows) * (n + m))


@compiled
def _fill_envelope(step_phi: np.ndarray, step_gamma: np.ndarray, samples: np.ndarray, rows: np.ndarray,
                   table: np.ndarray) -> None:
    """``table`` (k, S, R, n + m): the rows ``rows`` of ``[Φ(t_i), Γ(t_i)]`` of each model, by the
    recurrence ``Φ ← Φ₁ Φ``, ``Γ ← Φ₁ Γ + Γ₁`` from ``(I, 0)``, held after its ``samples``. Loops with
    the sums in a fixed order, not BLAS matrix products, whose last bits depend on the BLAS kernel
    (the step ``Φ₁, Γ₁`` still comes from a matrix exponential); no Python loop over the samples (up
    to 2,048 per model)."""
    k, n, m = step_gamma.shape
    phi, gamma = np.empty((n, n)), np.empty((n, m))
    new_phi, new_gamma = np.empty((n, n)), np.empty((n, m))
    for j in range(k):
        for r in range(n):
            for c in range(n):
                phi[r, c] = 1.0 if r == c else 0.0
            for c in range(m):
                gamma[r, c] = 0.0
        for i in range(table.shape[1]):
            for q in range(rows.shape[0]):
                for c in range(n):
                    table[j, i, q, c] = phi[rows[q], c]
                for c in range(m):
                    table[j, i, q, n + c] = gamma[rows[q], c]
            if i + 1 >= samples[j]:
                continue
            for r in range(n):
                for c in range(n):
                    total = 0.0
                    for t in range(n):
                        total += step_phi[j, r, t] * phi[t, c]
                    new_phi[r, c] = total
                for c in range(m):
                    total = 0.0
                    for t in range(n):
                        total += step_phi[j, r, t] * gamma[t, c]
                    new_gamma[r, c] = total + step_gamma[j, r, c]
            phi, new_phi = new_phi, phi
            gamma, new_gamma = new_gamma, gamma


def peak_speed(table: np.ndarray, state: np.ndarray, action: np.ndarray, rows: int = 1) -> np.ndarray:
    """Largest ``|Vx|`` (with ``rows`` > 1: the norm of those velocity components) [m/s] over a
    look-ahead (:func:`envelope_table`), input ``action`` held.

    ``table`` (S, ·) shared by a batch of states (..., n), or one table per state (..., S, ·).
    """
    z = np.concatenate([state, action], axis=-1)
    if rows > 1:
        size = z.shape[-1]
        if table.ndim == 2:  # one matrix product for the batch, then the norm over the rows
            speeds = z @ table.reshape(-1, size).T
        else:
            speeds = np.einsum("...sk,...k->...s", table.reshape(*table.shape[:-2], -1, size), z)
        speeds = speeds.reshape(*speeds.shape[:-1], -1, rows)
        return np.sqrt(np.max(np.einsum("...sr,...sr->...s", speeds, speeds), axis=-1))
    if table.ndim == 2:
        return np.abs(z @ table.T).max(axis=-1)
    return np.abs(np.matmul(table, z[..., None])).max(axis=(-2, -1))


class EnvelopeEstimator:
    """The envelope of one model: :func:`envelope_table` kept for repeated queries."""

    def __init__(self, model: PlanarModel, periods: float = 1.0,
                 samples_per_fast_period: int = 32, max_samples: int = 2048) -> None:
        self.table = envelope_table(model.A, model.B, periods, samples_per_fast_period, max_samples)

    def peak_speed(self, state: np.ndarray, action: np.ndarray) -> float:
        """max over the look-ahead of ``|Vx|`` [m/s], input ``action`` held."""
        return float(peak_speed(self.table, state, action))
