"""The centred sail's axial flight: distance, speed, Doppler factor and spot widening over time
(docs/physics.md §5, §7, §12).

Integrates :func:`sail_env.physics.rigid3d.body.axial_rates` once (DOP853, dense output), so
the quantities that set the lateral dynamics along the flight — the push's Doppler factor
``(1−β)/(1+β)`` and the spot's widening ``max(1, D/L0)`` — and the distance ``D(t)`` that
turns a ground pointing angle into a spot offset can be read at any time.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.integrate

from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.relativity import diffraction_scale, doppler_push_factor
from sail_env.physics.rigid3d.body import RigidSail, axial_rates

#: Flights a :class:`DrawFlights` with diffraction integrates across the draws' range of ``F/m``.
DRAW_NODES = 9


@dataclasses.dataclass(frozen=True)
class Flight:
    """The flight of one sail design from rest.

    Attributes:
        duration_s: Beam time covered (the cut-off).
        relativistic: ``True``: ``d(γβ)/dt`` with the Doppler factor; ``False``: Newton's
            ``dβ/dt = F/(m c)`` at the centred push (the planar model's flight).
        diffraction_length_m: ``L0``, beyond which the spot widens as ``D/L0``.
    """

    duration_s: float
    relativistic: bool
    diffraction_length_m: float
    _solution: scipy.integrate.OdeSolution

    def momentum(self, t: np.ndarray | float) -> np.ndarray:
        """``γβ`` (``β`` when not relativistic) at lab time ``t``."""
        return self._solution(np.asarray(t, float))[0]

    def distance(self, t: np.ndarray | float) -> np.ndarray:
        """``D(t)`` [m] from the laser."""
        return self._solution(np.asarray(t, float))[1]

    def beta(self, t: np.ndarray | float) -> np.ndarray:
        p = self.momentum(t)
        return p / np.sqrt(1.0 + p**2) if self.relativistic else p

    def speed(self, t: np.ndarray | float) -> np.ndarray:
        """Axial speed ``Vz`` [m/s]: the denominator of the pointing angle."""
        return self.beta(t) * SPEED_OF_LIGHT

    def power_factor(self, t: np.ndarray | float) -> np.ndarray:
        """Doppler factor of every radiation force (1 when not relativistic)."""
        return doppler_push_factor(self.beta(t)) if self.relativistic else np.ones_like(np.asarray(t, float))

    def beam_scale(self, t: np.ndarray | float) -> np.ndarray:
        """How much wider the spot is than at ``L0``."""
        return diffraction_scale(self.distance(t), self.diffraction_length_m)


def fly(sail: RigidSail, duration_s: float, relativistic: bool = True,
        diffraction_length_m: float = math.inf) -> Flight:
    """Integrate the centred sail's axial flight from rest over ``duration_s`` seconds."""
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s must be finite and > 0, got {duration_s}")
    if not diffraction_length_m > 0:
        raise ValueError(f"diffraction_length_m must be > 0, got {diffraction_length_m}")

    def rhs(_t: float, y: np.ndarray) -> tuple[float, float]:
        return axial_rates(sail, float(y[0]), float(y[1]), diffraction_length_m, relativistic)

    solution = scipy.integrate.solve_ivp(rhs, (0.0, duration_s), [0.0, 0.0], method="DOP853",
                                         rtol=1e-10, atol=1e-12, dense_output=True)
    if not solution.success:
        raise RuntimeError(f"flight integration failed: {solution.message}")
    return Flight(duration_s, relativistic, diffraction_length_m, solution.sol)


class DrawFlights:
    """The flights of sails with ``r`` times the nominal sail's ``F/m`` (a parameter draw), for
    ``1/r_max ≤ r ≤ r_max``, all read at their own lab time ``t`` (docs/physics.md §14).

    Substituting ``τ = r t`` and ``D̃ = r D`` in the axial law turns the flight of ratio ``r`` into
    the nominal sail's with the diffraction length ``r L0``, read at ``τ``. Without diffraction
    that is the nominal flight itself (``q_r(t) = q(r t)``, ``D_r(t) = D(r t)/r``): one
    integration, exact. With diffraction the flights are integrated at :data:`DRAW_NODES`
    ratios equally spaced in ``ln r`` (the nominal one among them) and each quantity at ``τ`` is
    interpolated linearly in ``ln r`` between the two nodes around the draw.
    """

    def __init__(self, sail: RigidSail, duration_s: float, relativistic: bool, diffraction_length_m: float,
                 largest_ratio: float) -> None:
        count = DRAW_NODES if math.isfinite(diffraction_length_m) and largest_ratio > 1 else 1
        self.log_ratios = np.linspace(-math.log(largest_ratio), math.log(largest_ratio), count)
        self.diffraction_length_m = diffraction_length_m
        self.flights = [fly(sail, duration_s * largest_ratio, relativistic, diffraction_length_m * math.exp(x))
                        for x in self.log_ratios]
        self.nominal = self.flights[count // 2]

    def _read(self, quantity: str, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        ratio, t = np.broadcast_arrays(np.atleast_1d(np.asarray(ratio, float)), np.asarray(t, float))
        scaled = ratio * t
        if np.any(scaled > self.nominal.duration_s * (1 + 1e-12)):
            raise ValueError(f"flight time {float(np.max(t))} s is beyond the integrated flight "
                             f"({self.nominal.duration_s} s at the nominal push)")
        if len(self.flights) == 1:
            return getattr(self.nominal, quantity)(scaled)
        position = np.interp(np.log(ratio), self.log_ratios, np.arange(len(self.flights)))
        low = np.minimum(position.astype(np.int64), len(self.flights) - 2)
        frac = position - low
        values = np.stack([getattr(f, quantity)(scaled) for f in self.flights])
        below = np.take_along_axis(values, low[None], axis=0)[0]
        above = np.take_along_axis(values, low[None] + 1, axis=0)[0]
        return (1 - frac) * below + frac * above

    def speed(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        return self._read("speed", ratio, t)

    def power_factor(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        return self._read("power_factor", ratio, t)

    def distance(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        return self._read("distance", ratio, t) / ratio

    def beam_scale(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        return diffraction_scale(self.distance(ratio, t), self.diffraction_length_m)
