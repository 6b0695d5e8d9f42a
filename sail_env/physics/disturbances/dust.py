"""Interplanetary dust swept up by the sail: random kicks of its lateral speeds and tilt rates
(a compound Poisson process; docs/physics.md §15)."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from sail_env.physics.disturbance import ImpulseDisturbance, register
from sail_env.physics.rigid3d.limits import DUST_SPEED_M_S, check_dust, check_grain_mass
from sail_env.physics.rigid3d.plant import OMEGA_X, OMEGA_Y, VX, VY


@register
@dataclasses.dataclass(frozen=True)
class Dust(ImpulseDisturbance):
    """Attributes:
        dust_density_m3: Number density of grains [1/m³] the sail sweeps up at its speed.
        dust_grain_mass_kg: Mass of one grain [kg]: 0 or at least a hydrogen atom's.

    Both must be > 0 to switch the impacts on. The swept dust's drag must stay under 1 % of the
    push and no single grain may throw the sail out of the beam within a step
    (:func:`~sail_env.physics.rigid3d.limits.check_dust`). Only the rigid 3D sail carries it.
    """

    dust_density_m3: float = 0.0
    dust_grain_mass_kg: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        check_grain_mass(self.dust_grain_mass_kg)

    def check(self, plant: Any) -> None:
        if not hasattr(plant, "linearisation"):
            raise ValueError(f"dust_density_m3 and dust_grain_mass_kg need the rigid 3D sail (its tilt rates and "
                             f"inertia); {type(plant).__name__} has none")
        check_dust(plant.config, plant.linearisation, plant.parameter_spread, self.dust_density_m3,
                   self.dust_grain_mass_kg)

    def rows(self, plant: Any) -> tuple[int, ...]:
        return VX, VY, OMEGA_X, OMEGA_Y

    def rate_and_kick(self, plant: Any, p: Any, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The sail of aperture ``a`` sweeps ``n π a² v`` grains a second at the impact speed ``v``;
        a grain of mass ``m_g`` hitting at a uniformly random point of the disc kicks each tilt rate by
        ``m_g v y / I_t`` (``y`` of RMS ``a/2``) and each lateral speed by ``m_g u / m`` (``u`` its own
        speed per axis). Nominal mass and inertia."""
        lin = plant.linearisation
        radius = plant.aperture_radius_m
        speed = np.hypot(plant.speed(p, t), DUST_SPEED_M_S)
        rate = self.dust_density_m3 * math.pi * radius**2 * speed
        grain = self.dust_grain_mass_kg
        lateral = np.full_like(speed, grain * DUST_SPEED_M_S / math.sqrt(3.0) / lin.mass_kg)
        angular = grain * speed * 0.5 * radius / lin.inertia[0, 0]
        return rate, np.stack([lateral, lateral, angular, angular], axis=-1)
