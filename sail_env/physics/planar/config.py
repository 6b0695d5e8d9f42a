"""The planar sail's configuration: one validated dataclass in SI units, and presets.

The geometry follows the seed paper (Team 258, MCM Problem A): a spherical-cap
sail of aperture radius ``a`` and radius of curvature ``R`` (centre of curvature
on the laser side, ``R = inf`` for a flat sail), a payload on rigid struts a
distance ``L`` behind the sail vertex, and the centre of mass (CoM) a distance
``Lc`` behind the vertex. The moment of inertia is the seed's eq 10.
"""

from __future__ import annotations

import dataclasses
import math

from sail_env.physics import seed
from sail_env.physics.checks import check_below_light_speed, check_timing, real_number
from sail_env.physics.constants import SPEED_OF_LIGHT


@dataclasses.dataclass(frozen=True)
class SailConfig(seed.Timing, seed.SailBody):
    """Planar light-sail parameters, SI units throughout; the defaults are the seed's design point
    (:mod:`sail_env.physics.seed`, whose fields every sail model shares).

    Attributes:
        aperture_radius_m: Sail aperture radius ``a``; the flat-top beam has the same radius.
        curvature_radius_m: Sail radius of curvature ``R``; ``math.inf`` is a flat sail.
        com_distance_m: Distance ``Lc`` from the sail vertex back to the centre of mass.
        strut_length_m: Distance ``L`` from the sail vertex back to the payload.
        sail_mass_kg: Sail mass ``m_sail`` (concentrated at the vertex, seed eq 10).
        craft_mass_kg: Payload mass ``m_craft``.
        push_force_n: Axial radiation force ``F`` (constant while the beam is on).
        beam_cutoff_s: Beam time ``t_cut``; the flight direction is scored then.
        control_step_s: Control (and observation) period.
        control_window_s: Length of the actively controlled part of the flight.
        control_start_s: Flight time at which control starts (the state is propagated
            from launch until then).
    """

    push_force_n: float = seed.PUSH_FORCE_N

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = real_number(getattr(self, field.name), field.name)
            object.__setattr__(self, field.name, value)  # NumPy scalars and ints stored as float
            if math.isnan(value):
                raise ValueError(f"{field.name} must not be NaN")
            if math.isinf(value) and field.name != "curvature_radius_m":
                raise ValueError(f"{field.name} must be finite, got {value}")
        positive = (
            "aperture_radius_m", "com_distance_m", "sail_mass_kg", "craft_mass_kg",
            "push_force_n", "beam_cutoff_s", "control_step_s", "control_window_s",
        )
        for name in positive:
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not self.curvature_radius_m >= self.aperture_radius_m:
            raise ValueError(
                "curvature_radius_m must be >= aperture_radius_m "
                f"({self.aperture_radius_m} m) or inf for a flat sail, got {self.curvature_radius_m}"
            )
        if not self.strut_length_m >= self.com_distance_m:
            raise ValueError(
                f"strut_length_m must be >= com_distance_m ({self.com_distance_m} m), "
                f"got {self.strut_length_m}"
            )
        check_timing(self.control_start_s, self.control_step_s, self.control_window_s, self.beam_cutoff_s)
        check_below_light_speed(self.axial_acceleration_m_s2, self.beam_cutoff_s, "push_force_n and beam_cutoff_s")

    @property
    def total_mass_kg(self) -> float:
        return self.sail_mass_kg + self.craft_mass_kg

    @property
    def moment_of_inertia_kg_m2(self) -> float:
        """Seed eq 10: ``I = m_sail Lc^2 + m_craft (L - Lc)^2`` (point masses on a massless strut)."""
        return seed.moment_of_inertia(self.sail_mass_kg, self.craft_mass_kg, self.com_distance_m, self.strut_length_m)

    @property
    def curvature_per_m(self) -> float:
        """``1/R``: zero for a flat sail."""
        return 1.0 / self.curvature_radius_m

    @property
    def axial_acceleration_m_s2(self) -> float:
        return self.push_force_n / self.total_mass_kg

    def replace(self, **changes: float) -> "SailConfig":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)


def push_force_from_laser(power_w: float, reflectance: float = 1.0) -> float:
    """Axial force on an opaque sail at normal incidence: ``F = (1 + η) P / c``.

    The reflected fraction ``η`` transfers ``2P/c`` per unit power (seed eq 1), the
    absorbed rest ``1 - η`` transfers ``P/c``.
    """
    if not power_w > 0 or math.isinf(power_w):
        raise ValueError(f"power_w must be finite and > 0, got {power_w}")
    if not 0.0 <= reflectance <= 1.0:
        raise ValueError(f"reflectance must be in [0, 1], got {reflectance}")
    return (1.0 + reflectance) * power_w / SPEED_OF_LIGHT


#: The seed paper's design point, converted from its CGS code (a = 200 cm, R = Lc = 1000 cm,
#: L = 2000 cm, 0.5 g + 0.5 g, F = 1e7 dyn for 600 s). ``R = Lc``: the tilt is neutral.
SEED = SailConfig()

#: Centre of curvature between the sail and the CoM (R < Lc): two undamped coupled modes
#: (70.7 and 122.5 rad/s). R = 4 m keeps the modes apart: near R ≈ 6.7 m their
#: frequencies cross, and a ±10 % spread of masses and lengths (a strut shorter than
#: 2 Lc) makes them coalesce into a growing oscillation (flutter; at R = 7 m in a few per
#: cent of draws, at 8 m in ~20 %).
DEEP_DISH = SailConfig(curvature_radius_m=4.0)

#: The seed's flat sail (R -> inf, seed eqs 18-19): exponentially unstable.
FLAT = SailConfig(curvature_radius_m=math.inf)

PRESETS: dict[str, SailConfig] = {"seed": SEED, "deep_dish": DEEP_DISH, "flat": FLAT}
