"""Velocity-dependent radiation forces of order v/c: Doppler and aberration damping
(docs/physics.md §13; Mackintosh et al. 2024, arXiv:2401.16924, in a 2D model).

An element moving with velocity ``u = β c`` (lab, relative to the frame co-moving with the
centred sail) sees, in its own rest frame, the beam aberrated to ``k' = k − β⊥``
(``β⊥ = β − (β·k) k``) and its intensity Doppler-reduced to ``I' = I (1 − 2 β·k)``. There it
feels the static law, ``2ρ I' (n·k')² dA/c`` along ``n`` and ``α I' (n·k') dA/c`` along
``k'``; the force is the same in the lab to first order (a mirror's energy balance is
zero in its frame; absorbed power is re-emitted symmetrically there). Per node of the
quadrature, whose weight is the projected area ``du dv = (n·k) dA``, the change to first
order is::

    δf = flux [ −2 (β·k)(2ρ c₀ n + α k) − 4ρ (n·β⊥) n − α (n·β⊥)/c₀ k − α β⊥ ],   c₀ = n·k

with ``u = v + ω × r`` for a rigid sail. Linear in the rates, so the Jacobian with respect
to ``(vx, vy, ωx, ωy)`` is exact from unit rates. For a spherical dish of aperture ``a``
in a flat-top beam of its size the lateral force is ``−ρ (P/c)(a²/R²)(v/c)`` and passes
through the centre of curvature; a flat mirror rotating about a diameter feels
``τ = −ρ (P/c) a² ω/c`` (the Doppler difference across it). These terms scale with the
power like every radiation term; the frames' axial motion is accounted for only through
that power (the Doppler factor), corrections of order ``β_z²`` are left out, and so are the
spin's (tangential, symmetric) element velocities.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.rigid3d.body import RigidSail
from sail_env.physics.rigid3d.linearise import RATES, Linearisation, linearise

#: Imaginary parts below this [rad/s] are round-off of the neutral tilt's double zero, not modes.
MIN_FREQUENCY = 1e-2


def element_force_change(flux: np.ndarray, normal: np.ndarray, direction: np.ndarray, beta: np.ndarray,
                         reflectivity: float, absorptivity: float) -> np.ndarray:
    """First-order change ``δf`` (..., 3) of each element's force for element velocities ``β``
    (..., 3) in units of ``c``; ``flux`` (...) is ``I du dv / c`` as in
    :meth:`~sail_env.physics.rigid3d.forces.RadiationModel.elements`."""
    cos_incidence = np.sum(normal * direction, axis=-1, keepdims=True)
    along = np.sum(beta * direction, axis=-1, keepdims=True)
    across = beta - along * direction
    normal_across = np.sum(normal * across, axis=-1, keepdims=True)
    reflected = -4.0 * reflectivity * (along * cos_incidence + normal_across) * normal
    absorbed = -absorptivity * ((2.0 * along + normal_across / cos_incidence) * direction + across)
    return flux[..., None] * (reflected + absorbed)


def rate_jacobian(sail: RigidSail, power_factor: float = 1.0, beam_scale: float = 1.0) -> np.ndarray:
    """``∂(Fx, Fy, τx, τy)/∂(vx, vy, ωx, ωy)`` (4, 4) at the centred pose [N s/m, N s, N m s/m, N m s]."""
    config = sail.config
    flux, point, normal, direction = sail.radiation.elements(
        np.zeros((1, 3)), np.eye(3)[None], np.zeros((1, 2)), np.zeros((1, 2)),
        config.beam_power_w * power_factor, beam_scale)
    columns = []
    for j in range(4):
        rates = np.zeros(6)  # (v, ω), body = lab at the centred pose
        rates[(0, 1, 3, 4)[j]] = 1.0
        velocity = rates[:3] + np.cross(rates[3:], point)
        change = element_force_change(flux, normal, direction, velocity / SPEED_OF_LIGHT,
                                      config.reflectivity, config.absorptivity)
        force = change.sum(axis=(1, 2))[0]
        torque = np.cross(point, change).sum(axis=(1, 2))[0]
        columns.append([force[0], force[1], torque[0], torque[1]])
    return np.array(columns).T


def radiation_damping(sail: RigidSail, power_factor: float = 1.0, beam_scale: float = 1.0) -> np.ndarray:
    """The velocity terms' contribution (8, 8) to ``A`` (rows v̇, ω̇; columns v, ω)."""
    divisors = np.array([sail.mass, sail.mass, sail.inertia[0, 0], sail.inertia[0, 0]])[:, None]
    out = np.zeros((8, 8))
    out[np.ix_(RATES, RATES)] = rate_jacobian(sail, power_factor, beam_scale) / divisors
    return out


def damped_linearisation(sail: RigidSail, spin: float = 0.0, power_factor: float = 1.0, beam_scale: float = 1.0,
                         velocity_terms: bool = False) -> Linearisation:
    """:func:`~sail_env.physics.rigid3d.linearise.linearise`, with the v/c terms added to ``A``
    (and to the push sensitivity: they scale with the power) when ``velocity_terms``."""
    lin = linearise(sail, spin, power_factor, beam_scale)
    if not velocity_terms:
        return lin
    damping = radiation_damping(sail, power_factor, beam_scale)
    return dataclasses.replace(lin, A=lin.A + damping, push_sensitivity=lin.push_sensitivity + damping)


def mode_damping_rates(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(frequencies, decay rates)`` [rad/s, 1/s] of the distinct oscillating modes of ``A``,
    ascending in frequency (each lateral mode appears once, not per axis)."""
    eig = np.linalg.eigvals(a)
    eig = eig[eig.imag > MIN_FREQUENCY]
    eig = eig[np.argsort(eig.imag)]
    keep = np.concatenate([[True], np.diff(eig.imag) > 1e-6 * eig.imag[1:]]) if eig.size else np.array([], bool)
    # Degenerate x/y pairs: average their decay rates.
    groups = np.cumsum(keep) - 1
    frequencies = np.array([eig.imag[groups == g].mean() for g in range(int(keep.sum()))])
    decay = np.array([-eig.real[groups == g].mean() for g in range(int(keep.sum()))])
    return frequencies, decay
