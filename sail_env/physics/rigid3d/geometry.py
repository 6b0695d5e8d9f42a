"""Sail shapes in the body frame, ray intersection and mass distribution (docs/physics.md §6).

Body frame: origin at the CoM, ``z`` along the sail axis pointing away from the laser. Every
shape is axisymmetric with its vertex (the point on the axis) at ``z = Lc`` and a circular
rim of radius ``a`` in the plane ``z = z_rim``:

* dish: sphere of radius ``R`` centred at ``z_C = Lc − R`` (on the laser side), the cap
  around the vertex; rim at ``Lc − s`` with the sagitta ``s = R − √(R² − a²)``;
* balloon: sphere centred at ``z_C = Lc + R`` (beyond the vertex), the cap facing the laser;
  rim at ``Lc + s``;
* cone: apex at the vertex, rim at ``Lc − s`` (the dish's vertex and rim, straight sides);
* flat: disc at ``z = Lc``.

"Push normal" means the unit normal on the sail's lit side oriented along the push a
perfect mirror feels there (away from the laser).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from sail_env.physics.seed import moment_of_inertia
from sail_env.physics.rigid3d.config import RigidSailConfig

#: Gauss–Legendre nodes of the fixed radial quadrature of the sail's mass distribution.
MASS_NODES = 64


@dataclasses.dataclass(frozen=True)
class SailGeometry:
    shape: str
    aperture_m: float
    curvature_m: float
    com_distance_m: float

    @classmethod
    def from_config(cls, config: RigidSailConfig) -> "SailGeometry":
        return cls(config.shape, config.aperture_radius_m, config.curvature_radius_m, config.com_distance_m)

    @property
    def sagitta_m(self) -> float:
        if self.shape == "flat":
            return 0.0
        r, a = self.curvature_m, self.aperture_m
        return a**2 / (r + math.sqrt(r**2 - a**2))  # R − √(R² − a²) without cancellation

    @property
    def rim_z_m(self) -> float:
        sign = 1.0 if self.shape == "balloon" else -1.0
        return self.com_distance_m + sign * self.sagitta_m

    @property
    def centre_z_m(self) -> float:
        """Body ``z`` of the centre of curvature (dish and balloon only)."""
        if self.shape == "dish":
            return self.com_distance_m - self.curvature_m
        if self.shape == "balloon":
            return self.com_distance_m + self.curvature_m
        raise ValueError(f"a {self.shape} sail has no centre of curvature")

    def height(self, rho: np.ndarray) -> np.ndarray:
        """Body ``z`` of the surface at distance ``rho`` from the axis."""
        s = self.rim_z_m - self.com_distance_m  # signed depth of the rim
        if self.shape == "flat":
            return np.full_like(rho, self.com_distance_m)
        if self.shape == "cone":
            return self.com_distance_m + s * rho / self.aperture_m
        # Sphere: z − z_C = ∓√(R² − ρ²), measured from the vertex to avoid cancellation.
        depth = rho**2 / (self.curvature_m + np.sqrt(self.curvature_m**2 - rho**2))
        return self.com_distance_m + np.sign(s) * depth

    def slope(self, rho: np.ndarray) -> np.ndarray:
        """``|dz/dρ|`` of the surface."""
        if self.shape == "flat":
            return np.zeros_like(rho)
        if self.shape == "cone":
            return np.full_like(rho, self.sagitta_m / self.aperture_m)
        return rho / np.sqrt(self.curvature_m**2 - rho**2)

    def intersect(self, origin: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Where rays ``origin + t·direction`` (body frame, unit ``direction``, ``(..., 3)``) meet the
        sail, and the push normal there. The caller sends only rays inside the rim's shadow."""
        if self.shape == "flat":
            t = (self.com_distance_m - origin[..., 2]) / direction[..., 2]
            point = origin + t[..., None] * direction
            return point, np.broadcast_to(np.array([0.0, 0.0, 1.0]), point.shape)
        if self.shape in ("dish", "balloon"):
            centre = np.array([0.0, 0.0, self.centre_z_m])
            rel = origin - centre
            half_b = np.sum(rel * direction, axis=-1)
            c = np.sum(rel * rel, axis=-1) - self.curvature_m**2
            root = np.sqrt(half_b**2 - c)
            # The dish is the sphere's far side from the laser (exit point), the balloon its near side.
            t = -half_b + root if self.shape == "dish" else -half_b - root
            point = origin + t[..., None] * direction
            outward = (point - centre) / self.curvature_m
            return point, outward if self.shape == "dish" else -outward
        # Cone (Lc − z)² = κ² (x² + y²) with κ = s/a; the sail is the nappe towards the laser,
        # which a ray coming from the laser meets first (the smaller root).
        kappa = self.sagitta_m / self.aperture_m
        w0 = self.com_distance_m - origin[..., 2]
        qa = direction[..., 2] ** 2 - kappa**2 * np.sum(direction[..., :2] ** 2, axis=-1)
        qb = -2.0 * (w0 * direction[..., 2] + kappa**2 * np.sum(origin[..., :2] * direction[..., :2], axis=-1))
        qc = w0**2 - kappa**2 * np.sum(origin[..., :2] ** 2, axis=-1)
        root = np.sqrt(qb**2 - 4.0 * qa * qc)
        t = 2.0 * qc / (-qb + root)  # the smaller root of qa t² + qb t + qc, without cancellation
        point = origin + t[..., None] * direction
        rho = np.maximum(np.hypot(point[..., 0], point[..., 1]), 1e-300)
        normal = np.stack([kappa * point[..., 0] / rho, kappa * point[..., 1] / rho, np.ones_like(rho)], axis=-1)
        return point, normal / math.sqrt(1.0 + kappa**2)

    @functools.cached_property
    def mass_moments(self) -> tuple[float, float]:
        """``(⟨ρ²⟩, ⟨z²⟩)`` of a uniform areal density over the surface, from a fixed
        Gauss–Legendre quadrature in ``ρ`` with the area element ``2πρ √(1 + z'(ρ)²) dρ``."""
        x, w = np.polynomial.legendre.leggauss(MASS_NODES)
        rho = 0.5 * self.aperture_m * (x + 1.0)
        area = w * rho * np.sqrt(1.0 + self.slope(rho) ** 2)
        area = area / area.sum()
        z = self.height(rho)
        return float(area @ rho**2), float(area @ z**2)


def inertia_tensor(config: RigidSailConfig) -> np.ndarray:
    """Inertia tensor about the CoM (body frame): sail spread over its surface, point payload,
    struts a uniform rod on the axis from the payload to the vertex. Diagonal ``(I_t, I_t, I_a)``.

    The transverse moment is the seed's eq 10 for point masses at the vertex and the payload
    (:func:`sail_env.physics.seed.moment_of_inertia`) plus what the sail's spread changes.
    """
    geometry = SailGeometry.from_config(config)
    rho2, z2 = geometry.mass_moments
    lc, length = config.com_distance_m, config.strut_length_m
    transverse = moment_of_inertia(config.sail_mass_kg, config.craft_mass_kg, lc, length)
    transverse += config.sail_mass_kg * (0.5 * rho2 + z2 - lc**2)
    transverse += config.strut_mass_kg * (length**2 / 12.0 + (lc - 0.5 * length) ** 2)
    axial = config.sail_mass_kg * rho2
    return np.diag([transverse, transverse, axial])
