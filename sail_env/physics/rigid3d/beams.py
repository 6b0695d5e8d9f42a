"""Beam intensity profiles at the sail, normalised to unit total power (docs/physics.md §7).

Coordinates ``(u, v)`` lie in the plane across the beam, measured from its axis. Each
profile integrates to one over that plane; the force model multiplies by the power. The
spot the sail sees widens along the flight (``scale = D/L0`` beyond the diffraction
length, :func:`sail_env.physics.relativity.diffraction_scale`): every length scales by
``scale`` and, the power conserved, the intensity by ``1/scale²``.

* ``"flat-top"``: uniform disc of radius ``r_b`` (the seed's beam), hard edge.
* ``"annulus"``: uniform between ``r_in`` and ``r_b``, hard edges.
* ``"gaussian"``: ``2/(π w²) exp(−2 r²/w²)``, waist ``w = r_b``.
* ``"multi-gaussian"``: ``N`` equal Gaussians of waist ``w_l`` centred on a ring of radius
  ``r_b`` (Manchester & Loeb 2017: a dip in the middle, lobes near the rim).

Everything that depends on the kind of profile is decided here (its edges, the power a disc catches,
its smallest spot); the configuration (:meth:`~sail_env.physics.rigid3d.config.RigidSailConfig.beam`),
the force model and the diffraction tables ask a :class:`BeamProfile`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.special

BEAM_PROFILES = ("flat-top", "gaussian", "multi-gaussian", "annulus")


@dataclasses.dataclass(frozen=True)
class BeamProfile:
    """One beam's profile (module docstring): its ``kind`` (one of :data:`BEAM_PROFILES`), outer
    radius (a Gaussian's waist, the ring's radius), inner radius (an annulus's), the ring's lobes' waist
    and number."""

    kind: str
    radius_m: float
    inner_radius_m: float
    lobe_waist_m: float
    lobes: int

    @property
    def hard_edged(self) -> bool:
        return self.kind in ("flat-top", "annulus")

    @property
    def ring(self) -> bool:
        """Gaussian lobes on a ring, whose waist the quadrature must resolve."""
        return self.kind == "multi-gaussian"

    @property
    def edges(self) -> tuple[float, ...]:
        """Radii of the hard edges (none for Gaussians), outer first."""
        if not self.hard_edged:
            return ()
        return (self.radius_m, self.inner_radius_m) if self.kind == "annulus" else (self.radius_m,)

    def smallest_radius_m(self, min_waist_m: float, wavelength_m: float, inner_given: bool) -> float:
        """The smallest outer radius this kind of beam may have: a Gaussian's waist the quadrature
        resolves (``min_waist_m``), any ring, otherwise the wavelength (an annulus's default inner
        edge, half the outer radius, included: ``inner_given`` says whether it was set)."""
        low = {"gaussian": min_waist_m, "multi-gaussian": 0.0}.get(self.kind, wavelength_m)
        return 2.0 * low if self.kind == "annulus" and not inner_given else low

    def caught_fraction(self, aperture_m: float) -> float:
        """Fraction of the beam's power crossing a centred disc of radius ``aperture_m``."""
        a, outer = aperture_m, self.radius_m
        if self.hard_edged:
            inner = self.inner_radius_m if self.kind == "annulus" else 0.0
            # Ratios to the outer radius: no square overflows for any finite radius.
            caught = min(a / outer, 1.0) ** 2 - min(a / outer, inner / outer) ** 2
            return max(caught, 0.0) / (1.0 - (inner / outer) ** 2)
        sigma = 0.5 * (self.lobe_waist_m if self.ring else outer)
        centre = outer if self.ring else 0.0
        # A Gaussian of standard deviation σ per axis centred at r: |p|²/σ² is non-central χ² with 2 degrees.
        return float(scipy.special.chndtr((a / sigma) ** 2, 2, (centre / sigma) ** 2))  # ncx2.cdf without importing scipy.stats (0.35 s)

    def support(self, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Radii ``(r_in, r_out)`` between which the intensity is non-zero (scaled); ``inf`` for Gaussians.

        The quadrature integrates exactly between these edges instead of masking nodes.
        """
        scale = np.asarray(scale, dtype=float)
        if self.kind == "flat-top":
            return np.zeros_like(scale), self.radius_m * scale
        if self.kind == "annulus":
            return self.inner_radius_m * scale, self.radius_m * scale
        return np.zeros_like(scale), np.full_like(scale, np.inf)

    def intensity(self, u: np.ndarray, v: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Intensity per watt [1/m²] at ``(u, v)``; ``scale`` broadcasts against them.

        Hard-edged profiles return their inside value everywhere: the quadrature only
        places nodes inside their support.
        """
        scale = np.asarray(scale, dtype=float)
        u, v = u / scale, v / scale
        if self.kind == "flat-top":
            unit = np.full(np.broadcast_shapes(u.shape, v.shape), 1.0 / (math.pi * self.radius_m**2))
        elif self.kind == "annulus":
            unit = np.full(np.broadcast_shapes(u.shape, v.shape),
                           1.0 / (math.pi * (self.radius_m**2 - self.inner_radius_m**2)))
        elif self.kind == "gaussian":
            unit = _gaussian(u**2 + v**2, self.radius_m)
        else:
            angles = 2.0 * math.pi * np.arange(self.lobes) / self.lobes
            centres = self.radius_m * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
            du = u[..., None] - centres[:, 0]
            dv = v[..., None] - centres[:, 1]
            unit = _gaussian(du**2 + dv**2, self.lobe_waist_m).mean(axis=-1)
        return unit / scale**2


def _gaussian(r2: np.ndarray, waist: float) -> np.ndarray:
    return 2.0 / (math.pi * waist**2) * np.exp(-2.0 * r2 / waist**2)
