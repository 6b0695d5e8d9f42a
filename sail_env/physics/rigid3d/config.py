"""Configuration of the rigid 3D sail: shape, materials, masses, beam and quadrature (SI units).

The geometry extends the seed's planar model's (:class:`sail_env.physics.planar.config.SailConfig`):
the sail axis points away from the laser, the centre of mass (CoM) lies ``Lc`` behind the
sail's vertex (towards the laser), the payload ``L`` behind it. The defaults are the seed's
design point (:mod:`sail_env.physics.seed`: a = 2 m, R = Lc = 10 m, L = 20 m, 0.5 g + 0.5 g) in a flat-top beam of the
aperture's size whose power gives the seed's push ``2P/c = 100 N`` on a flat mirror.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

from sail_env.physics import seed
from sail_env.physics.checks import real_number
from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.mission import LASER_WAVELENGTH_M
from sail_env.physics.rigid3d.beams import BEAM_PROFILES, BeamProfile

SHAPES = ("dish", "balloon", "flat", "cone")

#: Beam power whose push on a perfect flat mirror catching all of it is the seed's 100 N.
SEED_BEAM_POWER_W = seed.PUSH_FORCE_N * SPEED_OF_LIGHT / 2.0
#: Largest ``R / a`` of a curved sail. The curvature's terms go as ``a/R``: at ``R = 1e4 a`` (a sag of
#: ``a/2e4``, 0.1 mm on the seed's 2 m sail) they are 1e-4 of the flat sail's, the surface quadrature's
#: own accuracy (:data:`WAIST_NODE_SPACINGS`), so a flatter sail is ``shape="flat"`` within the model's
#: accuracy; and the cone's ray intersection loses all precision from ~5e4 a.
MAX_CURVATURE_OVER_APERTURE = 1e4
#: Smallest fraction of the beam's power the centred sail must catch. The linearisation is about the
#: centred sail in its spot: a spot that misses it (an annulus whose hole is wider than the sail, lobes
#: far outside its rim, a spot far wider than it) leaves no push and no restoring force to linearise,
#: and the axial flight and the scored pointing ``V⊥/Vz`` divide by the push. Below 1 % the push is
#: under 1 N and the flight a hundredth of the design's: no longer a beam-riding sail.
MIN_CAUGHT_FRACTION = 0.01
#: A Gaussian waist must span this many mean radial spacings ``a / radial_nodes`` of the surface
#: quadrature: at 1.6 (a/10 at 16 nodes) the push is within 1e-4 of a 4x finer quadrature's
#: (at a/16: 3e-3; at a/100: 64 % off).
WAIST_NODE_SPACINGS = 1.6
#: Why ``beam_radius_m`` has its lower bound, per profile.
BEAM_RADIUS_LIMITS = {"flat-top": "no beam focuses below its wavelength",
                      "annulus": "its inner edge, half of it, no smaller than the wavelength",
                      "gaussian": f"the waist spans {WAIST_NODE_SPACINGS:g} radial node spacings of the surface quadrature",
                      "multi-gaussian": "the radius of the ring of lobes, which may be any"}


@dataclasses.dataclass(frozen=True)
class RigidSailConfig(seed.SailBody):
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
        check_choice("shape", self.shape, SHAPES)
        check_choice("beam_profile", self.beam_profile, BEAM_PROFILES)
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if field.type in ("str",) or value is None:
                continue
            if field.name in ("beam_lobes", "radial_nodes", "angular_nodes"):
                if isinstance(value, bool) or not isinstance(value, numbers.Integral):
                    raise ValueError(f"{field.name} must be an integer, got {value!r}")
                object.__setattr__(self, field.name, int(value))
                continue
            value = real_number(value, field.name)
            if not math.isfinite(value):
                raise ValueError(f"{field.name} must be finite, got {value}")
            object.__setattr__(self, field.name, value)  # NumPy scalars and ints stored as float
        positive = ("aperture_radius_m", "com_distance_m", "sail_mass_kg", "craft_mass_kg",
                    "beam_power_w", "beam_radius_m", "beam_inner_radius_m", "beam_lobe_waist_m")
        for name in positive:
            value = getattr(self, name)
            if value is not None and value <= 0:
                raise ValueError(f"{name} must be > 0, got {value}")
        if self.strut_mass_kg < 0:
            raise ValueError(f"strut_mass_kg must be >= 0, got {self.strut_mass_kg}")
        a = self.aperture_radius_m
        if self.shape != "flat" and not a < self.curvature_radius_m <= MAX_CURVATURE_OVER_APERTURE * a:
            raise ValueError(f"curvature_radius_m must be in ({a:g}, {MAX_CURVATURE_OVER_APERTURE * a:g}] m for a "
                             f"{self.shape} (above aperture_radius_m, at most {MAX_CURVATURE_OVER_APERTURE:g} times "
                             f"it: flatter is sail_shape='flat'), got {self.curvature_radius_m}")
        if not self.com_distance_m <= self.strut_length_m:
            raise ValueError(f"com_distance_m must be in (0, {self.strut_length_m:g}] m (the CoM lies between the sail "
                             f"and the payload, strut_length_m = {self.strut_length_m:g} m behind the vertex), "
                             f"got {self.com_distance_m}")
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
            if not value >= low:
                raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
        self._check_spot()

    def _check_spot(self) -> None:
        """The beam's radius within :meth:`beam_radius_range` (and a multi-Gaussian's lobes resolved)."""
        if self.beam().ring and not self.lobe_waist_m >= self.min_waist_m:
            raise ValueError(f"beam_lobe_waist_m must be >= {self.min_waist_m:.4g} m (a Gaussian waist spans "
                             f"{WAIST_NODE_SPACINGS:g} radial node spacings of the surface quadrature), "
                             f"got {self.lobe_waist_m}")
        low, high = self.beam_radius_range()
        if not low <= self.outer_beam_radius_m <= high:
            raise ValueError(f"beam_radius_m must be in {'(' if low == 0 else '['}{low:.4g}, {high:.4g}] m for the "
                             f"{self.beam_profile} beam on "
                             f"this sail ({BEAM_RADIUS_LIMITS[self.beam_profile]}; the sail must catch >= "
                             f"{MIN_CAUGHT_FRACTION:.0%} of its power), got {self.outer_beam_radius_m}")

    def beam_radius_range(self) -> tuple[float, float]:
        """``beam_radius_m``'s valid range: from the smallest spot the quadrature resolves (a Gaussian's
        waist) or a beam can focus to (its wavelength) to the widest whose power the sail still catches
        :data:`MIN_CAUGHT_FRACTION` of (bisected: the caught fraction falls as the radius grows)."""
        low = self.beam().smallest_radius_m(self.min_waist_m, LASER_WAVELENGTH_M, self.beam_inner_radius_m is not None)
        below, above = self.aperture_radius_m * 1e-3, self.aperture_radius_m / math.sqrt(MIN_CAUGHT_FRACTION) * 1e3
        for _ in range(60):
            middle = math.sqrt(below * above)
            below, above = (middle, above) if self.caught_fraction(outer_m=middle) >= MIN_CAUGHT_FRACTION else (below, middle)
        return low, below

    @property
    def min_waist_m(self) -> float:
        """Smallest Gaussian waist the surface quadrature resolves (:data:`WAIST_NODE_SPACINGS`)."""
        return WAIST_NODE_SPACINGS * self.aperture_radius_m / self.radial_nodes

    def caught_fraction(self, scale: float = 1.0, outer_m: float | None = None) -> float:
        """Fraction of the beam's power crossing the sail's disc of radius ``a`` (centred, the spot
        widened by ``scale``; with the outer radius ``outer_m`` instead of the configured one)."""
        return self.beam(outer_m).caught_fraction(self.aperture_radius_m / scale)

    def beam(self, outer_m: float | None = None) -> BeamProfile:
        """The beam's profile (with the outer radius ``outer_m`` instead of the configured one; a
        default inner radius follows it)."""
        outer = self.outer_beam_radius_m if outer_m is None else outer_m
        inner = 0.5 * outer if self.beam_inner_radius_m is None else self.beam_inner_radius_m
        return BeamProfile(self.beam_profile, outer, inner, self.lobe_waist_m, self.beam_lobes)

    @property
    def outer_beam_radius_m(self) -> float:
        """Flat-top or annulus outer radius, Gaussian waist or ring radius (default: ``a``)."""
        return self.aperture_radius_m if self.beam_radius_m is None else self.beam_radius_m

    @property
    def lobe_waist_m(self) -> float:
        return 0.5 * self.aperture_radius_m if self.beam_lobe_waist_m is None else self.beam_lobe_waist_m

    @property
    def total_mass_kg(self) -> float:
        return self.sail_mass_kg + self.craft_mass_kg + self.strut_mass_kg

    def replace(self, **changes) -> "RigidSailConfig":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)


def check_choice(name: str, value: object, choices: tuple[str, ...]) -> None:
    if not (isinstance(value, str) and value in choices):
        raise ValueError(f"{name} must be one of {choices}, got {value!r}")
