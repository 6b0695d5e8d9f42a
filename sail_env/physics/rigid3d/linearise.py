"""Linearisation of the rigid 3D sail about its centred equilibrium (docs/physics.md §9).

State ``s = (x, y, vx, vy, θx, θy, ωx, ωy)``: lateral CoM offsets and rates, the sail
axis's small-angle tilts (rotation-vector components: the axis leans to ``(θy, −θx)``)
and their rates. Input ``u = (d_x, d_y, ψ_x, ψ_y)``: beam offset and tilt (the slopes of
the beam direction). The planar model's ``(X, θ)`` is ``(x, θy)`` here, and ``(y, −θx)``
the other axis. With the sail spinning at ``Ω`` about its axis and ``I_t``, ``I_a`` the
transverse and axial moments::

    m v̇ = ∂F⊥/∂(q, u) · (q, u),    I_t ω̇x = τx − I_a Ω ωy,    I_t ω̇y = τy + I_a Ω ωx

(the linearised ``ω × I ω``). The wrench Jacobian comes from central differences of the
integrated radiation force (one batched call). Every radiation term scales with the beam
power, so the push sensitivity ``∂A/∂ln P`` is the radiation part of ``A`` and a power
command acts parametrically, not through ``B``.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from sail_env.physics.rigid3d.body import QUATERNION, RigidSail, rotation_matrices, state_from_small

STATE_NAMES = ("x", "y", "vx", "vy", "theta_x", "theta_y", "omega_x", "omega_y")
POSE = (0, 1, 4, 5)
RATES = (2, 3, 6, 7)
#: Relative central-difference step (of the aperture for lengths, of aperture/Lc for angles).
RELATIVE_STEP = 1e-6
#: Singular values below this fraction of the largest count as zero in the rank (the central
#: differences are accurate to ~1e-8 relative; an exact degeneracy shows as ~1e-10).
RANK_TOLERANCE = 1e-6


@dataclasses.dataclass(frozen=True)
class Linearisation:
    """``ds/dt = A s + B u`` and derived facts about one equilibrium.

    Attributes:
        A, B: System (8, 8) and input (8, 4) matrices.
        push_sensitivity: ``∂A/∂ln P`` (8, 8): the parametric input of a power command.
        push_n: Axial radiation force on the centred sail [N].
        mass_kg, inertia: Mass and the (3, 3) inertia tensor used.
        com_distance_m: ``Lc`` (the input scaling of :meth:`input_singular_values`).
    """

    A: np.ndarray
    B: np.ndarray
    push_sensitivity: np.ndarray
    push_n: float
    mass_kg: float
    inertia: np.ndarray
    com_distance_m: float

    @functools.cached_property
    def eigenvalues(self) -> np.ndarray:
        return np.linalg.eigvals(self.A)

    @property
    def growth_rate(self) -> float:
        return float(max(self.eigenvalues.real.max(), 0.0))

    @property
    def frequencies(self) -> tuple[float, ...]:
        """Distinct oscillation frequencies [rad/s] of the modes that oscillate, ascending."""
        imag = np.sort(self.eigenvalues.imag[self.eigenvalues.imag > 1e-9 * max(1.0, np.abs(self.eigenvalues).max())])
        distinct: list[float] = []
        for value in imag:
            if not distinct or value > distinct[-1] * (1 + 1e-6):
                distinct.append(float(value))
        return tuple(distinct)

    def input_singular_values(self) -> np.ndarray:
        """Singular values of ``B`` with inputs as displacements at the vertex (tilts × Lc)
        and rows as accelerations (angular ones × Lc), so that none is favoured by units."""
        scale_rows = np.array([1, 1, 1, 1, 1, 1, self.com_distance_m, self.com_distance_m])
        scale_cols = np.array([1.0, 1.0, 1.0 / self.com_distance_m, 1.0 / self.com_distance_m])
        return np.linalg.svd(scale_rows[:, None] * self.B * scale_cols, compute_uv=False)

    @property
    def input_rank(self) -> int:
        sv = self.input_singular_values()
        return int(np.sum(sv > RANK_TOLERANCE * sv[0])) if sv[0] > 0 else 0

    @property
    def input_condition(self) -> float:
        """``σ_max/σ_min`` of the scaled ``B`` (``inf`` when the smallest is exactly zero)."""
        sv = self.input_singular_values()
        return float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")


def wrench_jacobian(sail: RigidSail, power_factor: float = 1.0, beam_scale: float = 1.0) -> tuple[np.ndarray, float]:
    """``∂(Fx, Fy, τx, τy)/∂(x, y, θx, θy, d_x, d_y, ψ_x, ψ_y)`` (4, 8) at the centred pose (lab
    components) by central differences in one batched call, and the centred axial push."""
    config = sail.config
    h_length = RELATIVE_STEP * config.aperture_radius_m
    h_angle = h_length / max(config.com_distance_m, config.aperture_radius_m)
    steps = np.array([h_length, h_length, h_angle, h_angle] * 2)
    delta = np.concatenate([np.diag(steps), -np.diag(steps), np.zeros((1, 8))])
    states = state_from_small(x=delta[:, 0], y=delta[:, 1], theta_x=delta[:, 2], theta_y=delta[:, 3])
    force, torque_body = sail.wrench(states, delta[:, 4:], power_factor, beam_scale)
    rotation = rotation_matrices(states[:, QUATERNION])
    torque = np.einsum("nij,nj->ni", rotation, torque_body)
    wrench = np.concatenate([force[:, :2], torque[:, :2]], axis=-1)
    jacobian = (wrench[:8] - wrench[8:16]).T / (2.0 * steps)
    return jacobian, float(force[16, 2])


def linearise(sail: RigidSail, spin: float = 0.0, power_factor: float = 1.0,
              beam_scale: float = 1.0) -> Linearisation:
    """The linear model about the centred sail spinning at ``spin`` [rad/s] in a beam of
    ``power_factor`` times the configured power, widened by ``beam_scale``."""
    jacobian, push = wrench_jacobian(sail, power_factor, beam_scale)
    transverse, axial = sail.inertia[0, 0], sail.inertia[2, 2]
    radiation = np.zeros((8, 8))
    # Rows: v̇x, v̇y, ω̇x, ω̇y; columns of the pose (x, y, θx, θy).
    divisors = np.array([sail.mass, sail.mass, transverse, transverse])[:, None]
    radiation[np.ix_(RATES, POSE)] = jacobian[:, :4] / divisors
    a = radiation.copy()
    a[0, 2] = a[1, 3] = a[4, 6] = a[5, 7] = 1.0
    a[6, 7] = -axial * spin / transverse
    a[7, 6] = axial * spin / transverse
    b = np.zeros((8, 4))
    b[list(RATES), :] = jacobian[:, 4:] / divisors
    return Linearisation(a, b, radiation, push, sail.mass, sail.inertia.copy(), sail.config.com_distance_m)
