"""The seed paper's planar beam-riding model as a linear time-invariant system.

State ``s = (X, Vx, θ, ω)``: lateral offset of the CoM from the target line [m], its
rate [m/s], tilt of the sail axis [rad], its rate [rad/s]. Input ``u = (d, ψ)``: the
lateral offset of the beam axis at the CoM's range [m] and the beam's tilt [rad].

Seed eqs 16-17 (Team 258, with ``Lr ≈ Lc`` for ``a ≪ R``) and, for ``R → ∞``, 18-19::

    m Ẍ = F θ − k F Δ / R
    I θ̈ = −k F (Lc/R − 1) Δ,        Δ = X − d + Lc (θ − ψ),   k = 1/2

Derivation of the inputs. A perfect reflector is pushed along each element's normal,
so the net force leaves along the normal at the centroid of the lit patch, and for a
sphere every normal passes through the centre of curvature C, which sits at
``CoM + (Lc − R)·n`` (``n`` the sail axis, pointing away from the laser). The lit
patch is the overlap of the flat-top beam disc with the aperture; its centroid lies
half-way (``k = 1/2``) between the beam axis and the sail axis, which is where the
seed's factor ½ comes from. ``Δ`` is the distance from the beam axis to the sail
vertex: the vertex is at ``X + Lc θ``, the beam axis crosses its plane at ``d + Lc ψ``. To first order
the force's direction depends only on the sail's own tilt (``F θ``) and on where the
beam lands (``Δ``), not on the beam's angle of incidence: **the two inputs enter only
through the landing point ``d + Lc ψ``**, so ``B`` has rank one in this model. The
torque about the CoM is that of a force through C, ``(Lc − R) (F_x − θ F)``, which
gives the second equation; at ``Lc = R`` it vanishes identically and θ is neither
restored nor controllable.

The model is linear and time invariant while ``F`` is constant, so a step of any
length is exact with the matrix exponential (zero-order hold on the input).
"""

from __future__ import annotations

import dataclasses
import enum
import functools

import numpy as np
import scipy.linalg

from sail_env.physics.linear import LinearModel
from sail_env.physics.noise import WhiteNoise, mean_and_covariance, moment_generator, second_moment
from sail_env.physics.planar.config import SailConfig

#: Centroid factor of the lit lens between a flat-top beam and the aperture (seed eq 14).
OVERLAP_CENTROID_FACTOR = 0.5

STATE_NAMES = ("x", "vx", "theta", "omega")
INPUT_NAMES = ("beam_offset", "beam_tilt")
X, VX, THETA, OMEGA = range(4)
BEAM_OFFSET, BEAM_TILT = range(2)


class StabilityKind(str, enum.Enum):
    """Passive behaviour of the linear model."""

    UNSTABLE = "unstable"  # a mode grows exponentially (real or complex pair)
    NEUTRAL = "neutral"  # no divergence, but some direction has no restoring force
    OSCILLATION = "undamped oscillation"  # every mode is an undamped oscillation


@dataclasses.dataclass(frozen=True)
class Stability:
    """Eigen-analysis of the 4x4 system matrix.

    Attributes:
        kind: Classification (see :class:`StabilityKind`).
        eigenvalues: The four eigenvalues [1/s], exact from the 2x2 stiffness problem.
        growth_rate: Largest real part [1/s] (0 when nothing grows).
        frequencies: Angular frequencies of the oscillating modes [rad/s], ascending.
    """

    kind: StabilityKind
    eigenvalues: np.ndarray
    growth_rate: float
    frequencies: tuple[float, ...]


class PlanarModel(LinearModel):
    """``ds/dt = A s + B u`` for one :class:`SailConfig` (one model, many consumers)."""

    def __init__(self, config: SailConfig) -> None:
        self.config = config
        super().__init__(*system_matrices(**matrix_parameters(config)))

    @property
    def push_sensitivity(self) -> tuple[np.ndarray, np.ndarray]:
        """``(∂A/∂ln F, ∂B/∂ln F)``: every force term scales with the push ``F``."""
        return push_sensitivity(self.A, self.B)

    @functools.cached_property
    def stiffness(self) -> np.ndarray:
        """``K`` in ``q̈ = −K q`` for ``q = (X, θ)`` (so ``λ² = eig(−K)``)."""
        return -self.A[np.ix_([VX, OMEGA], [X, THETA])]

    @functools.cached_property
    def stability(self) -> Stability:
        """Eigenvalues ``λ = ±√μ`` with ``μ`` the roots of the 2x2 ``−K``, in closed form.

        The closed form keeps the double zero at ``Lc = R`` exact and, where the two mode
        frequencies cross (a double ``μ``), avoids the √eps splitting a general
        eigensolver makes of a defective matrix. A negative discriminant is flutter:
        the modes coalesce into a growing oscillation.
        """
        mu, flutter = stiffness_roots(-self.stiffness)
        roots = np.sqrt(mu)
        eigenvalues = np.concatenate([roots, -roots])
        growth = float(max(eigenvalues.real.max(), 0.0)) + 0.0  # + 0.0 turns -0.0 into 0.0
        frequencies = tuple(sorted(float(r.imag) for r in roots if r.imag > 0 and not flutter))
        if growth > 0.0:
            kind = StabilityKind.UNSTABLE
        elif np.any(mu == 0.0):
            kind = StabilityKind.NEUTRAL
        else:
            kind = StabilityKind.OSCILLATION
        return Stability(kind, eigenvalues, growth, frequencies)

    def equilibrium_speed(self, t: float) -> float:
        """Axial speed ``Vz = F t / m`` [m/s] (Newtonian, as in the seed's planar model)."""
        return self.config.axial_acceleration_m_s2 * t


def matrix_parameters(config: SailConfig) -> dict[str, float]:
    """The physical parameters :func:`system_matrices` takes, from one configuration."""
    return {"force": config.push_force_n, "mass": config.total_mass_kg,
            "inertia": config.moment_of_inertia_kg_m2, "com_distance": config.com_distance_m,
            "curvature_radius": config.curvature_radius_m}


def system_matrices(force, mass, inertia, com_distance, curvature_radius) -> tuple[np.ndarray, np.ndarray]:
    """``A`` (..., 4, 4) and ``B`` (..., 4, 2) of the module's equations; arguments broadcast."""
    force, mass, inertia, lc, radius = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (force, mass, inertia, com_distance, curvature_radius)))
    k = OVERLAP_CENTROID_FACTOR
    # Lc/R − 1 is computed as written so that Lc == R gives an exact zero torque.
    torque_factor = lc / radius - 1.0
    # d(acceleration)/d(Δ): the lateral force and torque per metre of landing offset.
    force_per_offset = -k * force * (1.0 / radius) / mass
    torque_per_offset = -k * force * torque_factor / inertia
    a = np.zeros((*force.shape, 4, 4))
    a[..., X, VX] = 1.0
    a[..., THETA, OMEGA] = 1.0
    a[..., VX, X] = force_per_offset
    a[..., VX, THETA] = force / mass + force_per_offset * lc
    a[..., OMEGA, X] = torque_per_offset
    a[..., OMEGA, THETA] = torque_per_offset * lc
    b = np.zeros((*force.shape, 4, 2))
    b[..., VX, 0] = -force_per_offset
    b[..., VX, 1] = -force_per_offset * lc
    b[..., OMEGA, 0] = -torque_per_offset
    b[..., OMEGA, 1] = -torque_per_offset * lc
    return a, b


def push_sensitivity(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(∂A/∂ln F, ∂B/∂ln F)``: every entry but the kinematic ones scales with the push."""
    a_push = a.copy()
    a_push[..., X, VX] = 0.0
    a_push[..., THETA, OMEGA] = 0.0
    return a_push, b.copy()


def stiffness_roots(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Roots ``μ`` (..., 2) of the 2x2 ``m = −K`` in closed form, and whether they flutter.

    The eigenvalues of the 4x4 system are ``±√μ``. The larger root is taken without
    cancellation and the other from the product of roots; a discriminant within
    round-off of zero (where the mode frequencies cross) is taken as zero, and roots
    within round-off of zero as zero, so the seed point's double zero stays exact. A
    negative discriminant is flutter: the modes coalesce into a growing oscillation.
    """
    scale = np.maximum(np.abs(m).max(axis=(-2, -1)), 1e-300)
    trace = m[..., 0, 0] + m[..., 1, 1]
    det = m[..., 0, 0] * m[..., 1, 1] - m[..., 0, 1] * m[..., 1, 0]
    disc = (m[..., 0, 0] - m[..., 1, 1]) ** 2 + 4.0 * m[..., 0, 1] * m[..., 1, 0]
    disc = np.where(np.abs(disc) <= 1e-12 * scale**2, 0.0, disc)
    flutter = disc < 0
    big = 0.5 * (trace + np.copysign(np.sqrt(np.abs(disc)), trace))
    small = np.divide(det, big, out=np.zeros_like(big), where=big != 0)
    real = np.stack([big, small], axis=-1).astype(complex)
    coalesced = 0.5 * (trace[..., None] + np.array([1j, -1j]) * np.sqrt(np.abs(disc))[..., None])
    mu = np.where(flutter[..., None], coalesced, real)
    mu = np.where(np.abs(mu) <= 1e-12 * scale[..., None], 0.0, mu)
    return mu, flutter


def rates(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched growth rate (..., ) and oscillation frequencies (..., 2; NaN where a mode does
    not oscillate) of planar system matrices, from :func:`stiffness_roots`."""
    mu, flutter = stiffness_roots(a[..., [VX, OMEGA], :][..., [X, THETA]])
    roots = np.sqrt(mu)
    growth = np.maximum(np.abs(roots.real).max(axis=-1), 0.0)
    oscillating = (roots.imag > 0) & ~flutter[..., None]
    return growth, np.where(oscillating, roots.imag, np.nan)


def propagate_moments(model: PlanarModel, mean: np.ndarray, cov: np.ndarray,
                      action: np.ndarray, duration: float,
                      noise: WhiteNoise) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of the state after ``duration`` s with ``action`` held (the beam's
    jitter on its landing offset, :data:`BEAM_OFFSET`; :mod:`sail_env.physics.noise`)."""
    if not duration >= 0:
        raise ValueError(f"duration must be >= 0, got {duration}")
    action = np.asarray(action, dtype=float)
    if noise.beam_jitter_psd_m2s == 0 and noise.push_psd_s == 0:
        # Noise-free: the exact propagator, free of the cancellation in M − mean meanᵀ.
        phi, gamma = model.discretize(duration)
        return phi @ mean + gamma @ action, phi @ cov @ phi.T
    gen = moment_generator(model.A, model.B, action, noise, model.push_sensitivity, (BEAM_OFFSET,))
    return mean_and_covariance(scipy.linalg.expm(gen * duration) @ second_moment(mean, cov))


def pointing_error(model: PlanarModel, state: np.ndarray, t: float) -> float:
    """``|Vx| / Vz`` [rad] for a state at flight time ``t`` (beam cut off then)."""
    return abs(float(state[VX])) / model.equilibrium_speed(t)
