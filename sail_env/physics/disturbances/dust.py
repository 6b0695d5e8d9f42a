"""Interplanetary dust swept up by the sail: random kicks of its lateral speeds and tilt rates
(a compound Poisson process; docs/physics.md §15), and the limits that keep the impacts a
perturbation. The plant supplies what they depend on (its rows, its sail, its fastest flight)."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from sail_env.physics.constants import HYDROGEN_MASS_KG
from sail_env.physics.disturbance import ImpulseDisturbance, register

#: Largest axial drag of the swept-up dust (``n m_g π a² v²``, which the model leaves out) as a
#: fraction of the push: the impacts must stay a perturbation of a beam-riding sail.
MAX_DUST_DRAG_FRACTION = 0.01
#: Mean speed [m/s] of interplanetary grains at 1 AU (Grün et al. 1985): with the sail's axial
#: speed it sets the impact speed; its per-axis share ``/√3`` sets the lateral momentum of a grain.
DUST_SPEED_M_S = 2.0e4


@register
@dataclasses.dataclass(frozen=True)
class Dust(ImpulseDisturbance):
    """Attributes:
        dust_density_m3: Number density of grains [1/m³] the sail sweeps up at its speed.
        dust_grain_mass_kg: Mass of one grain [kg]: 0 or at least a hydrogen atom's.

    Both must be > 0 to switch the impacts on. The swept dust's drag must stay under 1 % of the
    push and no single grain may throw the sail out of the beam within a step
    (:func:`check_dust`). Only a plant with tilt rates (``tilt_rate_rows``: the rigid 3D sail) carries it.
    """

    dust_density_m3: float = 0.0
    dust_grain_mass_kg: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        check_grain_mass(self.dust_grain_mass_kg)

    def check(self, plant: Any) -> None:
        if not hasattr(plant, "tilt_rate_rows"):
            raise ValueError(f"dust_density_m3 and dust_grain_mass_kg need the rigid 3D sail (its tilt rates and "
                             f"inertia); {type(plant).__name__} has none")
        check_dust(plant, self.dust_density_m3, self.dust_grain_mass_kg)

    def rows(self, plant: Any) -> tuple[int, ...]:
        return (*plant.velocity_rows, *plant.tilt_rate_rows)

    def at_speed(self, plant: Any, speed: Any, xp: Any = np) -> tuple[Any, Any]:
        """The sail of aperture ``a`` sweeps ``n π a² v`` grains a second at the impact speed ``v`` (its
        axial ``speed`` and the grains' own); a grain of mass ``m_g`` hitting at a uniformly random point
        of the disc kicks each tilt rate by ``m_g v y / I_t`` (``y`` of RMS ``a/2``) and each lateral
        speed by ``m_g u / m`` (``u`` its own speed per axis). Nominal mass and inertia."""
        lin = plant.linearisation
        radius = plant.aperture_radius_m
        impact = xp.hypot(speed, DUST_SPEED_M_S)
        rate = self.dust_density_m3 * math.pi * radius**2 * impact
        grain = self.dust_grain_mass_kg
        lateral = xp.full_like(impact, grain * DUST_SPEED_M_S / math.sqrt(3.0) / lin.mass_kg)
        angular = grain * impact * 0.5 * radius / lin.inertia[0, 0]
        return rate, xp.stack([lateral, lateral, angular, angular], axis=-1)


def check_grain_mass(grain_mass_kg: float) -> None:
    """A grain is 0 (no dust) or at least a hydrogen atom: nothing lighter can be swept up."""
    if 0 < grain_mass_kg < HYDROGEN_MASS_KG:
        raise ValueError(f"dust_grain_mass_kg must be 0 (no dust) or >= {HYDROGEN_MASS_KG:.4g} kg (a hydrogen atom), "
                         f"got {grain_mass_kg}")


def check_dust(plant: Any, density_m3: float, grain_mass_kg: float) -> None:
    """The impacts must stay a perturbation: their drag ``n m_g π a² v²`` under
    :data:`MAX_DUST_DRAG_FRACTION` of the push, and no single grain (hitting the rim at the fastest
    speed) kicking the sail out of the small-angle regime or the beam within a control step (the
    start limits' rule). ``plant`` supplies its linearisation (push, mass, inertia), aperture, tilt
    limit, configuration (its control step) and its flight's fastest speed (a Newtonian bound)."""
    lin, a, tilt = plant.linearisation, plant.aperture_radius_m, plant.tilt_limit_rad
    dt = plant.config.control_step_s
    speed = math.hypot(plant.fastest_speed_m_s, DUST_SPEED_M_S)
    densest = MAX_DUST_DRAG_FRACTION * lin.push_n / (grain_mass_kg * math.pi * a**2 * speed**2)
    if density_m3 > densest:
        raise ValueError(f"dust_density_m3 must be <= {densest:.4g} per m³ for grains of {grain_mass_kg:g} kg (the "
                         f"swept dust's drag at {speed:.4g} m/s under {MAX_DUST_DRAG_FRACTION:.0%} of the push), "
                         f"got {density_m3}")
    heaviest = min(tilt / dt * lin.inertia[0, 0] / (speed * a), a / dt * lin.mass_kg * math.sqrt(3) / DUST_SPEED_M_S)
    if grain_mass_kg > heaviest:
        raise ValueError(f"dust_grain_mass_kg must be <= {heaviest:.4g} kg (one grain hitting the rim at {speed:.4g} "
                         f"m/s must not throw the sail out of the beam or the small-angle regime within a control "
                         f"step), got {grain_mass_kg}")
