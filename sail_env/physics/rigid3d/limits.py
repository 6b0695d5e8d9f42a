"""The valid ranges of the 3D flight's settings that depend on the sail and its flight (docs/physics.md
§12-§15), checked when a :class:`~sail_env.physics.rigid3d.plant.RigidPlant` is built: each refusal is one
``ValueError`` naming the setting and its range, and the reason is the physics the model stands on.

The flight is bounded by its Newtonian law ``D = a t²/2``, ``v = a t`` at the fastest parameter
draw's acceleration and the largest power command, up to twice the cut-off (the latest a cut-off
jitter allows): the relativistic law and the spot's widening only slow it, so the bounds are safe.
"""

from __future__ import annotations

import math

from sail_env.physics.constants import HYDROGEN_MASS_KG
from sail_env.physics.linear_plant import MAX_TILT_RAD
from sail_env.physics.rigid3d.config import MIN_CAUGHT_FRACTION

#: Largest relative power command ``u₅``. At −50 % the push is still half the nominal, so the push
#: noise on top (at most 25 %, whose 4σ step is a full push) never reverses it; and the step's push
#: expansion, exact to ``O(u₅⁵)``, is then within ~3e-10 of the step (1e-13 at ±10 %).
MAX_POWER_CONTROL = 0.5
#: Largest axial drag of the swept-up dust (``n m_g π a² v²``, which the model leaves out) as a
#: fraction of the push: the impacts must stay a perturbation of a beam-riding sail.
MAX_DUST_DRAG_FRACTION = 0.01
#: Mean speed [m/s] of interplanetary grains at 1 AU (Grün et al. 1985): with the sail's axial
#: speed it sets the impact speed; its per-axis share ``/√3`` sets the lateral momentum of a grain.
DUST_SPEED_M_S = 2.0e4


def check_spin(spin_rad_s: float, control_step_s: float) -> None:
    """``|Ω| ≤ π / dt``: the spin turns the sail by at most half a turn per control step. Faster, the
    observations sample the rotating sail below its Nyquist rate (the payload's torque, fixed in the lab
    frame here, turns at Ω in truth); at the seed's 5 ms that is 628 rad/s, a rim speed of 1.3 km/s on a
    2 m sail, about the breakup speed ``√(σ/ρ)`` of the strongest sail films (silicon nitride ~1.4 km/s)."""
    limit = math.pi / control_step_s
    if not abs(spin_rad_s) <= limit:
        raise ValueError(f"spin_rad_s must be in [-{limit:.4g}, {limit:.4g}] rad/s (at most half a turn per "
                         f"{control_step_s:g} s control step), got {spin_rad_s}")


def check_grain_mass(grain_mass_kg: float) -> None:
    """A grain is 0 (no dust) or at least a hydrogen atom: nothing lighter can be swept up."""
    if 0 < grain_mass_kg < HYDROGEN_MASS_KG:
        raise ValueError(f"dust_grain_mass_kg must be 0 (no dust) or >= {HYDROGEN_MASS_KG:.4g} kg (a hydrogen atom), "
                         f"got {grain_mass_kg}")


def _bisect(inside, low: float, high: float) -> float:
    """The largest ``x`` in ``[low, high]`` (geometrically) with ``inside(x)``, for ``inside`` true below
    some point and false above it."""
    for _ in range(80):
        middle = math.sqrt(low * high)
        low, high = (middle, high) if inside(middle) else (low, middle)
    return low


def fastest_flight(flight, lin, parameter_spread: float) -> tuple[float, float]:
    """The Newtonian bound's acceleration [m/s²] (the fastest draw at the largest power command) and
    horizon [s] (twice the cut-off) of a sail ``lin`` (a
    :class:`~sail_env.physics.rigid3d.linearise.Linearisation`) on ``flight`` (a
    :class:`~sail_env.physics.rigid3d.plant.RigidTaskConfig`)."""
    fastest = (1 + parameter_spread) / (1 - parameter_spread) * (1 + flight.power_control)
    return lin.push_n / lin.mass_kg * fastest, 2.0 * flight.beam_cutoff_s


def farthest_distance_m(flight, lin, parameter_spread: float) -> float:
    """The farthest the sail can be from the array at a cut-off (the bound of :func:`fastest_flight`)."""
    accel, horizon = fastest_flight(flight, lin, parameter_spread)
    return 0.5 * accel * horizon**2


def check_flight(flight, lin, parameter_spread: float) -> None:
    """The flight's settings whose range depends on the sail's push and mass (``lin``) and its flight
    (``flight``); the random disturbances check their own (:mod:`sail_env.physics.disturbances`)."""
    sail = flight.sail
    accel, _ = fastest_flight(flight, lin, parameter_spread)
    window_end = flight.control_start_s + flight.control_window_s
    window_distance = 0.5 * accel * window_end**2
    widest = _bisect(lambda s: sail.caught_fraction(s) >= MIN_CAUGHT_FRACTION, 1.0, 1e6)
    shortest = window_distance / widest
    if not flight.diffraction_length_m >= shortest:
        raise ValueError(f"diffraction_length_m must be >= {shortest:.4g} m (inf: no diffraction): the spot, widened "
                         f"by D/L0 up to the control window's end (D <= {window_distance:.4g} m), must still put >= "
                         f"{MIN_CAUGHT_FRACTION:.0%} of the beam on the sail, got {flight.diffraction_length_m}")


def check_dust(flight, lin, parameter_spread: float, density_m3: float, grain_mass_kg: float) -> None:
    """The impacts must stay a perturbation: their drag ``n m_g π a² v²`` under
    :data:`MAX_DUST_DRAG_FRACTION` of the push, and no single grain (hitting the rim at the fastest
    speed) kicking the sail out of the small-angle regime or the beam within a control step (the
    start limits' rule)."""
    sail, dt = flight.sail, flight.control_step_s
    a, tilt = sail.aperture_radius_m, min(sail.aperture_radius_m / sail.com_distance_m, MAX_TILT_RAD)
    accel, horizon = fastest_flight(flight, lin, parameter_spread)
    speed = math.hypot(accel * horizon, DUST_SPEED_M_S)
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
