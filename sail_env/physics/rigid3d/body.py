"""Nonlinear rigid-body dynamics of the sail in its beam, batched over sails (docs/physics.md §6).

State (N, 13): CoM position and velocity in the co-moving lab frame (origin on the
unperturbed beam axis, accelerating along it with the centred sail's push), the attitude
as a unit quaternion ``(w, x, y, z)`` (body to lab) and the body rates ``ω`` (body frame,
``ω_z`` the spin about the sail axis)::

    m r̈ = F(r, q, u) − m a₀ ẑ,      q̇ = ½ q ⊗ (0, ω),      I ω̇ = τ − ω × I ω

with ``F`` and ``τ`` the integrated radiation force and torque (:mod:`.forces`) and ``I``
the full inertia tensor (:func:`.geometry.inertia_tensor`). Gyroscopic coupling of the two
tilt axes by the spin comes from ``ω × I ω``, nothing is added by hand. The lateral and
rotational motion is Newtonian; the axial flight (:func:`axial_rates`) is relativistic.
"""

from __future__ import annotations

import functools

import numpy as np

from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.relativity import diffraction_scale, doppler_push_factor
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.forces import RadiationModel
from sail_env.physics.rigid3d.geometry import inertia_tensor

POSITION, VELOCITY, QUATERNION, RATES = slice(0, 3), slice(3, 6), slice(6, 10), slice(10, 13)
STATE_SIZE = 13
INPUT_NAMES = ("beam_offset_x", "beam_offset_y", "beam_tilt_x", "beam_tilt_y")


def rotation_matrices(quaternion: np.ndarray) -> np.ndarray:
    """Body-to-lab rotation matrices (..., 3, 3) of quaternions (..., 4), normalised first."""
    q = quaternion / np.linalg.norm(quaternion, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
    ], axis=-2)


def quaternion_from_rotation_vector(vector: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) of rotations by ``|v|`` about ``v/|v|``."""
    angle = np.linalg.norm(vector, axis=-1, keepdims=True)
    half_sinc = 0.5 * np.sinc(angle / (2.0 * np.pi))  # sin(θ/2)/θ, finite at θ = 0
    return np.concatenate([np.cos(0.5 * angle), half_sinc * vector], axis=-1)


def state_from_small(x=0.0, y=0.0, vx=0.0, vy=0.0, theta_x=0.0, theta_y=0.0, omega_x=0.0, omega_y=0.0,
                     spin=0.0, z=0.0, vz=0.0) -> np.ndarray:
    """A (N, 13) state from the tilt description the linear model uses (arguments broadcast).

    ``theta`` is the rotation vector ``(θx, θy, 0)`` (the sail axis leans to ``(θy, −θx)``),
    ``omega_x, omega_y`` the lab components of the angular velocity across the axis (the
    tilt rates), ``spin`` the rate about the sail axis.
    """
    values = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, float)) for v in
                                   (x, y, vx, vy, theta_x, theta_y, omega_x, omega_y, spin, z, vz)))
    x, y, vx, vy, tx, ty, wx, wy, spin, z, vz = values
    q = quaternion_from_rotation_vector(np.stack([tx, ty, np.zeros_like(tx)], axis=-1))
    rot = rotation_matrices(q)
    axis = rot[..., :, 2]
    across = np.stack([wx, wy, np.zeros_like(wx)], axis=-1)
    across -= np.sum(across * axis, axis=-1, keepdims=True) * axis
    rates_lab = across + spin[..., None] * axis
    rates_body = np.einsum("...ji,...j->...i", rot, rates_lab)
    return np.concatenate([np.stack([x, y, z, vx, vy, vz], axis=-1), q, rates_body], axis=-1)


def tilts(state: np.ndarray) -> np.ndarray:
    """Small-angle tilts ``(θx, θy)`` (..., 2) of the sail axis ``n``: ``θy = atan(n_x/n_z)``,
    ``θx = −atan(n_y/n_z)`` (the rotation-vector components to first order)."""
    axis = rotation_matrices(state[..., QUATERNION])[..., :, 2]
    return np.stack([np.arctan2(-axis[..., 1], axis[..., 2]), np.arctan2(axis[..., 0], axis[..., 2])], axis=-1)


def small_state(state: np.ndarray) -> np.ndarray:
    """The linear model's ``(x, y, vx, vy, θx, θy, ωx, ωy)`` (N, 8) of states (N, 13): the
    inverse of :func:`state_from_small` to first order (tilt rates are ω across the axis, lab)."""
    rotation = rotation_matrices(state[:, QUATERNION])
    omega = np.einsum("nij,nj->ni", rotation, state[:, RATES])
    axis = rotation[:, :, 2]
    across = omega - np.sum(omega * axis, axis=-1, keepdims=True) * axis
    return np.concatenate([state[:, [0, 1, 3, 4]], tilts(state), across[:, :2]], axis=-1)


class RigidSail:
    """One sail design in its beam: masses, inertia tensor, radiation model, equations of motion."""

    def __init__(self, config: RigidSailConfig) -> None:
        self.config = config
        self.radiation = RadiationModel(config)
        self.mass = config.total_mass_kg
        self.inertia = inertia_tensor(config)
        self.inverse_inertia = np.linalg.inv(self.inertia)

    def wrench(self, state: np.ndarray, inputs: np.ndarray, power_factor: np.ndarray | float = 1.0,
               beam_scale: np.ndarray | float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Force (lab) and torque (body) for states (N, 13) and beam commands (N, 4)."""
        return self.radiation.wrench(state[:, POSITION], rotation_matrices(state[:, QUATERNION]),
                                     inputs[:, :2], inputs[:, 2:4],
                                     self.config.beam_power_w * np.asarray(power_factor, float), beam_scale)

    @functools.lru_cache(maxsize=8)
    def centred_push(self, power_factor: float = 1.0, beam_scale: float = 1.0) -> float:
        """Axial force [N] on the centred, untilted sail: the co-moving frame's push."""
        force, _ = self.wrench(state_from_small(), np.zeros((1, 4)), power_factor, beam_scale)
        return float(force[0, 2])

    def rates(self, state: np.ndarray, inputs: np.ndarray, power_factor: float = 1.0,
              beam_scale: float = 1.0) -> np.ndarray:
        """``ds/dt`` (N, 13) in the frame accelerating with :meth:`centred_push`."""
        force, torque = self.wrench(state, inputs, power_factor, beam_scale)
        omega = state[:, RATES]
        q = state[:, QUATERNION]
        out = np.empty_like(state)
        out[:, POSITION] = state[:, VELOCITY]
        out[:, VELOCITY] = force / self.mass
        # The wrench is linear in the power: one cached push per beam scale serves any power factor.
        out[:, 5] -= power_factor * self.centred_push(1.0, float(beam_scale)) / self.mass
        w, v = q[:, :1], q[:, 1:]
        out[:, 6:7] = -0.5 * np.sum(v * omega, axis=-1, keepdims=True)
        out[:, 7:10] = 0.5 * (w * omega + np.cross(v, omega))
        momentum = omega @ self.inertia.T
        out[:, RATES] = (torque - np.cross(omega, momentum)) @ self.inverse_inertia.T
        return out


def axial_rates(sail: RigidSail, momentum_per_mass: float, distance_m: float,
                diffraction_length_m: float = np.inf, relativistic: bool = True) -> tuple[float, float]:
    """``(d(γβ)/dt, dD/dt)`` of the centred sail's flight (docs/physics.md §5).

    The push is the integrated radiation force on the centred sail in the spot at distance
    ``D`` (widened by :func:`~sail_env.physics.relativity.diffraction_scale`), reduced by the
    Doppler factor of :func:`~sail_env.physics.relativity.doppler_push_factor`: for a flat
    perfect mirror catching the whole beam this is Kulkarni, Lubin & Zhang's (2018) law.
    ``relativistic=False`` gives Newton's constant push (``γβ`` then stands for ``β``).
    """
    if relativistic:
        beta = momentum_per_mass / np.sqrt(1.0 + momentum_per_mass**2)
        doppler = float(doppler_push_factor(beta))
    else:
        beta, doppler = momentum_per_mass, 1.0
    scale = float(diffraction_scale(distance_m, diffraction_length_m))
    push = sail.centred_push(1.0, scale) * doppler
    return push / (sail.mass * SPEED_OF_LIGHT), beta * SPEED_OF_LIGHT
