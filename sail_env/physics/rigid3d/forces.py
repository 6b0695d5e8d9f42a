"""Radiation force and torque on a rigid sail, integrated over its lit surface (docs/physics.md §7).

Per element of area ``dA`` with incidence angle ``θᵢ`` (``cos θᵢ = n·k``, ``n`` the push
normal, ``k`` the beam direction) and local intensity ``I``:

* specular reflection (fraction ``ρ``): ``2 ρ I cos²θᵢ dA / c`` along ``n``;
* absorption (fraction ``α``): ``α I cos θᵢ dA / c`` along ``k``;
* transmission: nothing.

The integral is taken over the plane across the beam, where ``cos θᵢ dA = du dv``: the
rays that hit the sail are those inside the shadow of its rim, an exact ellipse (the
projection of a circle), so every ray reaches the lit face first. The quadrature uses
polar coordinates ``(r, φ)`` centred on the beam axis and, along each ray,
Gauss–Legendre nodes between the exact ends of the lit segment — the rim's ellipse (a
quadratic in ``r``) and the beam's hard edges (``r = r_in``, ``r_out``). No node is masked.
For a smooth beam the angles are equally spaced (the trapezoidal rule, spectrally
accurate for a smooth periodic integrand). Where a hard edge crosses the rim the lit
domain has corners, kinks in ``φ`` that would cost the trapezoidal rule its accuracy and,
because they move with the pose, make the stiffnesses converge only linearly; there the
angles at which each edge crosses the ellipse are found (sign changes on a grid refined
by Newton's method) and ``φ`` is integrated by Gauss–Legendre between them
(docs/physics.md §8 measures the convergence).

Everything is batched over a leading axis of sails and vectorised over the nodes.
"""

from __future__ import annotations

import math

import numpy as np

from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.geometry import SailGeometry


#: φ segments of the hard-edged rule: 4 fixed ones plus up to 4 crossings per edge.
ANGULAR_SEGMENTS = 12
#: Grid on which edge crossings are first located, and Newton steps refining each
#: (quadratic convergence from a bracket of 2π/256: round-off after four).
CROSSING_GRID = 256
NEWTON_STEPS = 5


class RadiationModel:
    """Force and torque of one beam profile on one sail shape, for batches of poses."""

    def __init__(self, config: RigidSailConfig) -> None:
        self.config = config
        self.geometry = SailGeometry.from_config(config)
        self.beam = config.beam()
        x, w = np.polynomial.legendre.leggauss(config.radial_nodes)
        self._radial_nodes = 0.5 * (x + 1.0)
        self._radial_weights = 0.5 * w
        self._uniform_angles = 2.0 * math.pi * (np.arange(config.angular_nodes) + 0.5) / config.angular_nodes
        x, w = np.polynomial.legendre.leggauss(max(1, config.angular_nodes // ANGULAR_SEGMENTS))
        self._segment_nodes, self._segment_weights = 0.5 * (x + 1.0), 0.5 * w

    def wrench(self, position: np.ndarray, rotation: np.ndarray, beam_offset: np.ndarray,
               beam_tilt: np.ndarray, power_w: np.ndarray | float,
               beam_scale: np.ndarray | float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Radiation force (lab frame) and torque about the CoM (body frame) [N, N m]; arguments
        as :meth:`elements`."""
        flux, point, normal, direction = self.elements(position, rotation, beam_offset, beam_tilt, power_w,
                                                       beam_scale)
        cos_incidence = np.sum(normal * direction, axis=-1)
        reflect = 2.0 * self.config.reflectivity * flux * cos_incidence
        force_elements = reflect[..., None] * normal + (self.config.absorptivity * flux)[..., None] * direction
        force_body = force_elements.sum(axis=(1, 2))
        torque_body = np.cross(point, force_elements).sum(axis=(1, 2))
        force_lab = np.einsum("nij,nj->ni", np.asarray(rotation, float), force_body)
        return force_lab, torque_body

    def elements(self, position: np.ndarray, rotation: np.ndarray, beam_offset: np.ndarray,
                 beam_tilt: np.ndarray, power_w: np.ndarray | float,
                 beam_scale: np.ndarray | float = 1.0) -> tuple[np.ndarray, ...]:
        """The quadrature's lit elements: ``(flux, point, normal, direction)``, each (N, angles,
        radial[, 3]) — the momentum flux ``I du dv / c`` [N] through each node's share of the plane
        across the beam, and the hit point, push normal and beam direction in the body frame.

        Args:
            position: ``(N, 3)`` CoM in the co-moving lab frame (z along the unperturbed beam).
            rotation: ``(N, 3, 3)`` body-to-lab rotation matrices.
            beam_offset: ``(N, 2)`` where the beam axis crosses the plane ``z = 0`` [m].
            beam_tilt: ``(N, 2)`` slopes ``(k_x/k_z, k_y/k_z)`` of the beam direction [rad].
            power_w: ``(N,)`` or scalar beam power (any Doppler or power command included).
            beam_scale: ``(N,)`` or scalar spot widening (1 up to the diffraction length).
        """
        position, rotation = np.asarray(position, float), np.asarray(rotation, float)
        n = position.shape[0]
        power = np.broadcast_to(np.asarray(power_w, float), (n,))
        scale = np.broadcast_to(np.asarray(beam_scale, float), (n,))
        k, across = _beam_frame(np.asarray(beam_tilt, float))
        anchor = np.concatenate([np.asarray(beam_offset, float), np.zeros((n, 1))], axis=-1)

        # The rim's shadow in beam coordinates: {c + M ξ : |ξ| <= 1}.
        geo = self.geometry
        rim_centre = position + geo.rim_z_m * rotation[:, :, 2]
        centre = np.einsum("nij,nj->ni", across, rim_centre - anchor)
        shadow = geo.aperture_m * np.einsum("nij,njk->nik", across, rotation[:, :, :2])
        inverse = np.linalg.inv(shadow)
        g0 = -np.einsum("nij,nj->ni", inverse, centre)  # (N, 2)
        inner, outer = self.beam.support(scale)
        if self.beam.hard_edged:
            angles, angle_weights = self._split_angles(g0, inverse, inner, outer)
        else:
            angles = np.broadcast_to(self._uniform_angles, (n, self._uniform_angles.size))
            angle_weights = np.full(angles.shape, 2.0 * math.pi / self._uniform_angles.size)
        directions = np.stack([np.cos(angles), np.sin(angles)], axis=-1)  # (N, angles, 2)
        g1 = np.einsum("nij,naj->nai", inverse, directions)
        qa = np.sum(g1 * g1, axis=-1)
        qb = np.einsum("ni,nai->na", g0, g1)
        qc = np.sum(g0 * g0, axis=-1)[:, None] - 1.0
        disc = qb**2 - qa * qc
        root = np.sqrt(np.maximum(disc, 0.0))
        far = (-qb + root) / qa
        # A ray whose lit part begins beyond the shadow's edge (an annulus's hole wider than the sail)
        # carries nothing: its empty interval sits on the edge, where the surface exists.
        lo = np.minimum(np.maximum(np.maximum((-qb - root) / qa, 0.0), inner[:, None]), far)
        hi = np.minimum(far, outer[:, None])
        hi = np.where(disc > 0, np.maximum(hi, lo), lo)  # a ray missing the shadow carries nothing

        r = lo[..., None] + (hi - lo)[..., None] * self._radial_nodes  # (N, angles, radial)
        weight = (hi - lo)[..., None] * self._radial_weights * r * angle_weights[..., None]
        u = r * directions[..., 0, None]
        v = r * directions[..., 1, None]
        flux = weight * self.beam.intensity(u, v, scale[:, None, None]) * (power / SPEED_OF_LIGHT)[:, None, None]

        # Rays into the body frame; the sail surface there.
        origin_lab = anchor[:, None, None, :] + u[..., None] * across[:, None, None, 0, :] \
            + v[..., None] * across[:, None, None, 1, :]
        origin = np.einsum("nji,nabj->nabi", rotation, origin_lab - position[:, None, None, :])
        k_body = np.einsum("nji,nj->ni", rotation, k)
        direction = np.broadcast_to(k_body[:, None, None, :], origin.shape)
        point, normal = geo.intersect(origin, direction)
        return flux, point, normal, direction

    def _split_angles(self, g0: np.ndarray, inverse: np.ndarray, inner: np.ndarray,
                      outer: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Angles (N, A) and weights of a Gauss–Legendre rule in ``φ`` whose segments end where
        the beam's edges cross the rim's shadow, so the ``φ`` integrand is smooth on each.

        An edge circle of radius ``r_e`` crosses the ellipse where ``|g0 + r_e G e(φ)| = 1``,
        a trigonometric polynomial of degree two in ``φ``: at most four crossings per edge.
        Unused break points fall back to fixed angles, which only split a smooth stretch.
        """
        n = g0.shape[0]
        grid = 2.0 * math.pi * np.arange(CROSSING_GRID) / CROSSING_GRID
        breaks = [np.broadcast_to(2.0 * math.pi * (np.arange(4) + 0.5) / 4, (n, 4))]
        for radius in (outer, inner):
            if not np.any(radius > 0):
                breaks.append(np.broadcast_to(2.0 * math.pi * (np.arange(4) + 0.25) / 4, (n, 4)))
                continue

            def excess(phi: np.ndarray, radius: np.ndarray = radius) -> tuple[np.ndarray, np.ndarray]:
                """``|g0 + r_e G e(φ)|² − 1`` and its derivative in ``φ``."""
                e = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
                de = np.stack([-np.sin(phi), np.cos(phi)], axis=-1)
                point = g0[:, None, :] + radius[:, None, None] * np.einsum("nij,nkj->nki", inverse, e)
                slope = radius[:, None, None] * np.einsum("nij,nkj->nki", inverse, de)
                return np.sum(point * point, axis=-1) - 1.0, 2.0 * np.sum(point * slope, axis=-1)

            sign = excess(np.broadcast_to(grid, (n, CROSSING_GRID)))[0] > 0
            change = sign != np.roll(sign, -1, axis=1)
            first = np.argsort(~change, axis=1, kind="stable")[:, :4]
            found = np.take_along_axis(change, first, axis=1) & (radius[:, None] > 0)
            lo = grid[first]
            hi = lo + 2.0 * math.pi / CROSSING_GRID
            crossing = 0.5 * (lo + hi)
            for _ in range(NEWTON_STEPS):  # kept inside the bracket
                value, slope = excess(crossing)
                step = np.divide(value, slope, out=np.zeros_like(value), where=slope != 0)
                crossing = np.clip(crossing - step, lo, hi)
            fallback = 2.0 * math.pi * (np.arange(4) + 0.25) / 4
            breaks.append(np.where(found, crossing, fallback))
        points = np.sort(np.concatenate(breaks, axis=1) % (2.0 * math.pi), axis=1)
        lengths = np.diff(points, axis=1, append=points[:, :1] + 2.0 * math.pi)
        angles = points[..., None] + lengths[..., None] * self._segment_nodes
        weights = lengths[..., None] * self._segment_weights
        return angles.reshape(n, -1), np.broadcast_to(weights, angles.shape).reshape(n, -1)


def _beam_frame(tilt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit beam direction ``k`` (N, 3) and an orthonormal basis across it (N, 2, 3), the first
    vector in the lab x-z plane (so the basis is the lab's x, y for an untilted beam)."""
    n = tilt.shape[0]
    k = np.concatenate([tilt, np.ones((n, 1))], axis=-1)
    k /= np.linalg.norm(k, axis=-1, keepdims=True)
    first = np.array([1.0, 0.0, 0.0]) - k[:, :1] * k
    first /= np.linalg.norm(first, axis=-1, keepdims=True)
    second = np.cross(k, first)
    return k, np.stack([first, second], axis=1)
