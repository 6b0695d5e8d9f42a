"""Exact first and second moments of the planar model driven by white noise.

Two disturbances act over the whole beam time:

* **beam pointing jitter**: white noise on the beam's landing offset ``d`` with
  two-sided power spectral density ``S_d`` [m² s] (additive: it enters
  through the first column of ``B``);
* **push fluctuation**: relative white noise ``ε`` on the push, ``F → F (1 + ε)``,
  PSD ``S_F`` [s]. Every force term scales with ``F``, so this noise multiplies the
  state: ``ds = (A s + B u) dt + (A_F s + B_F u) dW_F`` (Stratonovich, as befits
  physical noise of short correlation time).

For a linear system with additive and multiplicative white noise the second moment
``M = E[x xᵀ]`` of the augmented state ``x = (s, 1)`` obeys a *linear* ODE
(Itô form, with the Stratonovich drift correction ``½ S_F A_F²``)::

    dM/dt = Ã M + M Ãᵀ + S_F Ã_F M Ã_Fᵀ + S_d b bᵀ M[-1, -1]

For the planar model the correction vanishes (``Ã_F² = 0``: the push scales forces that depend on
positions only), so the two readings agree there; it matters for a push-scaled force on a velocity.

so it is propagated exactly by one matrix exponential of the vectorised generator
(after Van Loan 1978, IEEE TAC 23:395, who treats the additive case). The end state
is then drawn from the Gaussian with these moments: exact for additive noise, a
Gaussian closure with exact mean and covariance for the multiplicative part.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg
import scipy.special

from sail_env.physics.planar import PlanarModel, push_sensitivity


@dataclasses.dataclass(frozen=True)
class WhiteNoise:
    """Continuous-time white-noise intensities (two-sided PSDs).

    Attributes:
        beam_jitter_psd_m2s: PSD of the beam landing offset [m² s]. A per-step random
            offset of standard deviation σ held for ``dt`` has ``σ² dt``.
        push_psd_s: PSD of the relative push fluctuation [s]; per step ``σ_F² dt``.
    """

    beam_jitter_psd_m2s: float = 0.0
    push_psd_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("beam_jitter_psd_m2s", "push_psd_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")

    @classmethod
    def from_step_std(cls, jitter_std_m: float, push_std: float, dt: float) -> "WhiteNoise":
        """Intensities that match per-step noise of the given standard deviations."""
        return cls(jitter_std_m**2 * dt, push_std**2 * dt)


def moment_generator(a: np.ndarray, b: np.ndarray, action: np.ndarray, noise: WhiteNoise,
                     push: tuple[np.ndarray, np.ndarray] | None = None,
                     jitter_inputs: tuple[int, ...] = (0,), jitter_psd: np.ndarray | None = None,
                     state_psd: np.ndarray | None = None) -> np.ndarray:
    """The ``(n+1)² × (n+1)²`` matrix ``G`` with ``d vec(M)/dt = G vec(M)`` (row-major ``vec``),
    batched over the leading axes of ``a`` (..., n, n), ``b`` (..., n, m) and ``action`` (..., m).

    ``push`` is ``(∂A/∂ln F, ∂B/∂ln F)``, by default the planar model's; the beam jitter acts,
    independently and with the same PSD, on each input column in ``jitter_inputs``; ``jitter_psd``
    (batched like ``a``'s leading axes) replaces ``noise``'s beam-jitter PSD; ``state_psd`` (..., n, n)
    is white noise added to the state's derivative directly (its intensity matrix).
    """
    a_push, b_push = push_sensitivity(a, b) if push is None else push
    batch = np.broadcast_shapes(a.shape[:-2], b.shape[:-2], np.shape(action)[:-1])
    n = a.shape[-1]
    drift = np.zeros((*batch, n + 1, n + 1))
    drift[..., :n, :n] = a
    drift[..., :n, n] = np.einsum("...ij,...j->...i", b, action)
    mult = np.zeros((*batch, n + 1, n + 1))
    mult[..., :n, :n] = a_push
    mult[..., :n, n] = np.einsum("...ij,...j->...i", b_push, action)
    drift = drift + 0.5 * noise.push_psd_s * mult @ mult
    eye = np.eye(n + 1)
    gen = (_kron(drift, eye) + _kron(eye, drift)) + noise.push_psd_s * _kron(mult, mult)
    jitter = np.zeros((*batch, n + 1, n + 1))
    psd = noise.beam_jitter_psd_m2s if jitter_psd is None else np.asarray(jitter_psd)[..., None, None]
    for column in jitter_inputs:
        jitter[..., :n, :n] += psd * b[..., :, None, column] * b[..., None, :, column]
    if state_psd is not None:
        jitter[..., :n, :n] += state_psd
    gen[..., :, -1] += jitter.reshape(*batch, (n + 1) ** 2)
    return gen


def moment_growth_rate(a: np.ndarray, b: np.ndarray, noise: WhiteNoise) -> np.ndarray:
    """Growth rate [1/s] of the state's spread under the noise, batched like ``a`` (..., 4, 4): half
    the largest real part of the moment generator's eigenvalues. Multiplicative push noise makes
    the second moment grow even where the noise-free sail only oscillates (parametric excitation),
    so a long noisy propagation must be split by this rate, not the noise-free one."""
    generator = moment_generator(a, b, np.zeros((*a.shape[:-2], b.shape[-1])), noise)
    return 0.5 * np.linalg.eigvals(generator).real.max(axis=-1)


def _kron(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``np.kron`` over the last two axes, batched over the leading ones."""
    out = x[..., :, None, :, None] * y[..., None, :, None, :]
    return out.reshape(*out.shape[:-4], x.shape[-2] * y.shape[-2], x.shape[-1] * y.shape[-1])


def second_moment(mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``E[x xᵀ]`` of the augmented state ``x = (s, 1)``, flattened (..., (n + 1)²)."""
    batch, n = mean.shape[:-1], mean.shape[-1]
    second = np.zeros((*batch, n + 1, n + 1))
    second[..., :n, :n] = cov + mean[..., :, None] * mean[..., None, :]
    second[..., :n, n] = second[..., n, :n] = mean
    second[..., n, n] = 1.0
    return second.reshape(*batch, (n + 1) ** 2)


def mean_and_covariance(second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`second_moment` (the covariance symmetrised against round-off)."""
    n = round(np.sqrt(second.shape[-1])) - 1
    second = second.reshape(*second.shape[:-1], n + 1, n + 1)
    mean = second[..., :n, n].copy()
    cov = second[..., :n, :n] - mean[..., :, None] * mean[..., None, :]
    return mean, 0.5 * (cov + np.swapaxes(cov, -1, -2))


def propagate_moments(model: PlanarModel, mean: np.ndarray, cov: np.ndarray,
                      action: np.ndarray, duration: float,
                      noise: WhiteNoise) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of the state after ``duration`` s with ``action`` held."""
    if not duration >= 0:
        raise ValueError(f"duration must be >= 0, got {duration}")
    action = np.asarray(action, dtype=float)
    if noise.beam_jitter_psd_m2s == 0 and noise.push_psd_s == 0:
        # Noise-free: the exact propagator, free of the cancellation in M − mean meanᵀ.
        phi, gamma = model.discretize(duration)
        return phi @ mean + gamma @ action, phi @ cov @ phi.T
    gen = moment_generator(model.A, model.B, action, noise)
    return mean_and_covariance(scipy.linalg.expm(gen * duration) @ second_moment(mean, cov))


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
