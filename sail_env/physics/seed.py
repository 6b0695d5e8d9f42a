"""The seed paper's design point, converted from its CGS code to SI (Team 258, MCM Problem A:
a = 200 cm, R = Lc = 1000 cm, L = 2000 cm, 0.5 g + 0.5 g, F = 1e7 dyn for 600 s; docs/physics.md §1):
the fields every sail model shares, declared once with the seed's values as defaults (the planar
:class:`~sail_env.physics.planar.config.SailConfig`, the 3D
:class:`~sail_env.physics.rigid3d.config.RigidSailConfig` and
:class:`~sail_env.physics.rigid3d.plant.RigidTaskConfig` derive from them and validate them), so
that neither model is the other's base. Keyword-only: a model's own first field stays its first
positional argument (``RigidTaskConfig(sail, ...)``).
"""

from __future__ import annotations

import dataclasses

#: The seed's push ``F`` [N] (``2P/c`` on a flat mirror, so 15 GW of beam).
PUSH_FORCE_N = 100.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class SailBody:
    """The sail's geometry and masses (SI).

    Attributes:
        aperture_radius_m: Rim radius ``a``.
        curvature_radius_m: Radius of curvature ``R`` of the sail.
        com_distance_m: ``Lc``: from the sail's vertex back to the centre of mass (towards the laser).
        strut_length_m: ``L``: from the vertex back to the payload.
        sail_mass_kg: Sail mass ``m_sail``.
        craft_mass_kg: Payload mass ``m_craft``.
    """

    aperture_radius_m: float = 2.0
    curvature_radius_m: float = 10.0
    com_distance_m: float = 10.0
    strut_length_m: float = 20.0
    sail_mass_kg: float = 0.5e-3
    craft_mass_kg: float = 0.5e-3


@dataclasses.dataclass(frozen=True, kw_only=True)
class Timing:
    """The beam time and the control window (SI).

    Attributes:
        beam_cutoff_s: Beam time ``t_cut``; the flight direction is scored then.
        control_step_s: Control (and observation) period.
        control_window_s: Length of the actively controlled part of the flight.
        control_start_s: Flight time at which control starts (the state is propagated from
            launch until then).
    """

    beam_cutoff_s: float = 600.0
    control_step_s: float = 0.005
    control_window_s: float = 1.0
    control_start_s: float = 0.0

    @property
    def control_steps(self) -> int:
        """Number of control steps in the window (the window is rounded to whole steps)."""
        return max(1, round(self.control_window_s / self.control_step_s))


def moment_of_inertia(sail_mass, craft_mass, com_distance, strut_length):
    """Seed eq 10, ``m_sail Lc² + m_craft (L − Lc)²`` (scalars or arrays)."""
    return sail_mass * com_distance**2 + craft_mass * (strut_length - com_distance) ** 2
