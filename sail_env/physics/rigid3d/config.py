"""Configuration of the rigid 3D sail: shape, materials, masses, beam and quadrature (SI units).

The geometry extends :class:`sail_env.physics.config.SailConfig` (the seed's planar model):
the sail axis points away from the laser, the centre of mass (CoM) lies ``Lc`` behind the
sail's vertex (towards the laser), the payload ``L`` behind it. The defaults are the seed's
design point (a = 2 m, R = Lc = 10 m, L = 20 m, 0.5 g + 0.5 g) in a flat-top beam of the
aperture's size whose power gives the seed's push ``2P/c = 100 N`` on a flat mirror.
"""

from __future__ import annotations

import dataclasses
import math

from sail_env.physics.config import SEED
from sail_env.physics.constants import SPEED_OF_LIGHT

SHAPES = ("dish", "balloon", "flat", "cone")
BEAM_PROFILES = ("flat-top", "gaussian", "multi-gaussian", "annulus")

#: Beam power whose push on a perfect flat mirror catching all of it is the seed's 100 N.
SEED_BEAM_POWER_W = SEED.push_force_n * SPEED_OF_LIGHT / 2.0


@dataclasses.dataclass(frozen=True)
class RigidSailConfig:
    """Rigid 3D light sail in a laser beam (docs/physics.md §6).

    Attributes:
        shape: ``"dish"`` (spherical cap concave towards the laser: the seed's), ``"balloon"``
            (spherical cap convex towards the laser, Manchester & Loeb 2017), ``"flat"`` or
            ``"cone"`` (the cone through the dish's vertex and rim: same depth, straight sides).
        aperture_radius_m: Rim radius ``a``.
        curvature_radius_m: ``R`` of the dish and balloon, and the depth of the cone (that of the
            dish of this ``R``); must exceed ``a``. Ignored by the flat sail.
        com_distance_m: ``Lc``, vertex to CoM (towards the laser), as in the planar model.
        strut_length_m: ``L``, vertex to payload.
        sail_mass_kg: Sail mass, spread uniformly over its surface.
        craft_mass_kg: Payload mass (a point on the axis).
        strut_mass_kg: Strut mass (a thin rod on the axis from the payload to the vertex).
        reflectivity: Specularly reflected fraction ``ρ`` of the incident power.
        absorptivity: Absorbed fraction ``α``; the rest ``1 − ρ − α`` is transmitted.
        beam_profile: One of :data:`BEAM_PROFILES`.
        beam_power_w: Total beam power ``P`` (at the diffraction length ``L0`` and nearer).
        beam_radius_m: Flat-top radius, annulus outer radius, Gaussian waist (1/e² intensity
            radius) or the radius of the ring of Gaussians; ``None``: the aperture radius.
        beam_inner_radius_m: Annulus inner radius; ``None``: half the outer radius.
        beam_lobe_waist_m: Waist of each Gaussian of the ring; ``None``: half the aperture.
        beam_lobes: Number of Gaussians on the ring (Manchester & Loeb 2017 use four).
        radial_nodes: Gauss–Legendre nodes along each ray of the surface quadrature.
        angular_nodes: Rays of the surface quadrature (equally spaced for smooth beams; for
            hard-edged beams Gauss–Legendre on 12 segments between the edges' corners).
    """

    shape: str = "dish"
    aperture_radius_m: float = SEED.aperture_radius_m
    curvature_radius_m: float = SEED.curvature_radius_m
    com_distance_m: float = SEED.com_distance_m
    strut_length_m: float = SEED.strut_length_m
    sail_mass_kg: float = SEED.sail_mass_kg
    craft_mass_kg: float = SEED.craft_mass_kg
    strut_mass_kg: float = 0.0
    reflectivity: float = 1.0
    absorptivity: float = 0.0
    beam_profile: str = "flat-top"
    beam_power_w: float = SEED_BEAM_POWER_W
    beam_radius_m: float | None = None
    beam_inner_radius_m: float | None = None
    beam_lobe_waist_m: float | None = None
    beam_lobes: int = 4
    radial_nodes: int = 16
    angular_nodes: int = 128

    def __post_init__(self) -> None:
        _check_choice("shape", self.shape, SHAPES)
        _check_choice("beam_profile", self.beam_profile, BEAM_PROFILES)
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if field.type in ("str",) or value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"{field.name} must be a real number, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"{field.name} must be finite, got {value}")
        positive = ("aperture_radius_m", "com_distance_m", "sail_mass_kg", "craft_mass_kg",
                    "beam_power_w", "beam_radius_m", "beam_inner_radius_m", "beam_lobe_waist_m")
        for name in positive:
            value = getattr(self, name)
            if value is not None and value <= 0:
                raise ValueError(f"{name} must be > 0, got {value}")
        if self.strut_mass_kg < 0:
            raise ValueError(f"strut_mass_kg must be >= 0, got {self.strut_mass_kg}")
        if self.shape != "flat" and not self.curvature_radius_m > self.aperture_radius_m:
            raise ValueError(f"curvature_radius_m must be > aperture_radius_m ({self.aperture_radius_m} m) "
                             f"for a {self.shape}, got {self.curvature_radius_m}")
        if not self.strut_length_m >= self.com_distance_m:
            raise ValueError(f"strut_length_m must be >= com_distance_m ({self.com_distance_m} m), "
                             f"got {self.strut_length_m}")
        for name in ("reflectivity", "absorptivity"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")
        if self.reflectivity + self.absorptivity > 1.0:
            raise ValueError("reflectivity + absorptivity must be <= 1, got "
                             f"{self.reflectivity} + {self.absorptivity}")
        if self.beam_inner_radius_m is not None and not self.beam_inner_radius_m < self.outer_beam_radius_m:
            raise ValueError(f"beam_inner_radius_m must be < the outer radius ({self.outer_beam_radius_m} m), "
                             f"got {self.beam_inner_radius_m}")
        for name, low in (("beam_lobes", 1), ("radial_nodes", 2), ("angular_nodes", 8)):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= low):
                raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")

    @property
    def outer_beam_radius_m(self) -> float:
        """Flat-top or annulus outer radius, Gaussian waist or ring radius (default: ``a``)."""
        return self.aperture_radius_m if self.beam_radius_m is None else self.beam_radius_m

    @property
    def inner_beam_radius_m(self) -> float:
        return 0.5 * self.outer_beam_radius_m if self.beam_inner_radius_m is None else self.beam_inner_radius_m

    @property
    def lobe_waist_m(self) -> float:
        return 0.5 * self.aperture_radius_m if self.beam_lobe_waist_m is None else self.beam_lobe_waist_m

    @property
    def total_mass_kg(self) -> float:
        return self.sail_mass_kg + self.craft_mass_kg + self.strut_mass_kg

    def replace(self, **changes) -> "RigidSailConfig":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)


def _check_choice(name: str, value: object, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {choices}, got {value!r}")
