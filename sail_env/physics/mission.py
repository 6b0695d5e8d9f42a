"""Mission-level formulas of the seed paper (Team 258), SI units."""

from __future__ import annotations

from sail_env.physics.constants import LIGHT_YEAR, SPEED_OF_LIGHT, STEFAN_BOLTZMANN

PROXIMA_DISTANCE_LY = 4.25
EARTH_MOON_DISTANCE_M = 3.844e8  # mean; the seed rounds to 4e8 m


def pointing_tolerance_rad(miss_distance_m: float = EARTH_MOON_DISTANCE_M,
                           distance_ly: float = PROXIMA_DISTANCE_LY) -> float:
    """Seed eq 20: largest flight-direction error that passes within ``miss_distance_m``."""
    if not (miss_distance_m > 0 and distance_ly > 0):
        raise ValueError("miss_distance_m and distance_ly must be > 0")
    return miss_distance_m / (distance_ly * LIGHT_YEAR)


def thermal_acceleration_limit(emissivity: float, reflectance: float, absorptance: float,
                               temperature_k: float, areal_density_kg_m2: float) -> float:
    """Seed eq 4: ``a = (4σ/c) ε η T⁴ / (α ρd)`` [m/s²].

    The absorbed power ``α P`` must be radiated from both faces, ``2 σ ε A T⁴``.
    """
    for name, value in (("emissivity", emissivity), ("reflectance", reflectance),
                        ("absorptance", absorptance)):
        if not 0 < value <= 1:
            raise ValueError(f"{name} must be in (0, 1], got {value}")
    if not (temperature_k > 0 and areal_density_kg_m2 > 0):
        raise ValueError("temperature_k and areal_density_kg_m2 must be > 0")
    return (4 * STEFAN_BOLTZMANN / SPEED_OF_LIGHT) * emissivity * reflectance * temperature_k**4 / (
        absorptance * areal_density_kg_m2)


def required_figure_of_merit(acceleration_m_s2: float, temperature_k: float,
                             areal_density_kg_m2: float) -> float:
    """Seed eq 24: the smallest ``ε η / α`` that allows ``acceleration_m_s2`` at ``T``."""
    if not (acceleration_m_s2 > 0 and temperature_k > 0 and areal_density_kg_m2 > 0):
        raise ValueError("acceleration_m_s2, temperature_k and areal_density_kg_m2 must be > 0")
    return acceleration_m_s2 * areal_density_kg_m2 * SPEED_OF_LIGHT / (
        4 * STEFAN_BOLTZMANN * temperature_k**4)


def distance_flown_m(acceleration_m_s2: float, t: float) -> float:
    """``D = a t²/2`` at constant acceleration from rest (the planar model's flight)."""
    return 0.5 * acceleration_m_s2 * t**2


def one_way_light_delay_s(acceleration_m_s2: float, t: float) -> float:
    """Time light needs from the laser to a sail launched ``t`` seconds ago: ``D(t)/c``.

    Light chasing the receding sail needs ``1/(1 − β)`` times longer; during the early,
    controllable flight ``β < 1e-2`` and ``D(t)/c`` is accurate to a per cent.
    """
    return distance_flown_m(acceleration_m_s2, t) / SPEED_OF_LIGHT


# The ground array and its laser (docs/physics.md §12).
#: Laser wavelength of the Starshot point design (Parkin 2018).
LASER_WAVELENGTH_M = 1.06e-6
#: Diameter of the ground phased array: Lubin's (2016) DE-STAR 4, 10 km, 100 GW class.
ARRAY_DIAMETER_M = 10e3
#: Kulkarni, Lubin & Zhang's (2018) geometry factor for a circular array.
CIRCULAR_ARRAY_FACTOR = 1.22


def diffraction_length_m(spot_radius_m: float, array_diameter_m: float = ARRAY_DIAMETER_M,
                         wavelength_m: float = LASER_WAVELENGTH_M) -> float:
    """``L0 = d·D/(2λα)`` (Kulkarni, Lubin & Zhang 2018) for a spot of diameter ``D = 2 r``: the
    distance up to which the array can keep its spot that small (it widens as ``D/L0`` beyond)."""
    return array_diameter_m * 2.0 * spot_radius_m / (2.0 * wavelength_m * CIRCULAR_ARRAY_FACTOR)
