"""The valid ranges of the 3D flight's settings that depend on the sail and its flight (docs/physics.md
§12-§15), checked when a :class:`~sail_env.physics.rigid3d.plant.RigidPlant` is built: each refusal is one
``ValueError`` naming the setting and its range, and the reason is the physics the model stands on.

The flight is bounded by its Newtonian law ``D = a t²/2``, ``v = a t`` at the fastest parameter
draw's acceleration and the largest power command, up to twice the cut-off (the latest a cut-off
jitter allows): the relativistic law and the spot's widening only slow it, so the bounds are safe.
"""

from __future__ import annotations

import math

from sail_env.physics.rigid3d.config import MIN_CAUGHT_FRACTION

#: Largest relative power command ``u₅``. At −50 % the push is still half the nominal, so the push
#: noise on top (at most 25 %, whose 4σ step is a full push) never reverses it; and the step's push
#: expansion, exact to ``O(u₅⁵)``, is then within ~3e-10 of the step (1e-13 at ±10 %).
MAX_POWER_CONTROL = 0.5


def check_spin(spin_rad_s: float, control_step_s: float) -> None:
    """``|Ω| ≤ π / dt``: the spin turns the sail by at most half a turn per control step. Faster, the
    observations sample the rotating sail below its Nyquist rate (the payload's torque, fixed in the lab
    frame here, turns at Ω in truth); at the seed's 5 ms that is 628 rad/s, a rim speed of 1.3 km/s on a
    2 m sail, about the breakup speed ``√(σ/ρ)`` of the strongest sail films (silicon nitride ~1.4 km/s)."""
    limit = math.pi / control_step_s
    if not abs(spin_rad_s) <= limit:
        raise ValueError(f"spin_rad_s must be in [-{limit:.4g}, {limit:.4g}] rad/s (at most half a turn per "
                         f"{control_step_s:g} s control step), got {spin_rad_s}")


def _bisect(inside, low: float, high: float) -> float:
    """The largest ``x`` in ``[low, high]`` (geometrically) with ``inside(x)``, for ``inside`` true below
    some point and false above it."""
    for _ in range(80):
        middle = math.sqrt(low * high)
        low, high = (middle, high) if inside(middle) else (low, middle)
    return low


def fastest_flight(task, lin, parameter_spread: float) -> tuple[float, float]:
    """The Newtonian bound's acceleration [m/s²] (the fastest draw at the largest power command) and
    horizon [s] (twice the cut-off) of a sail ``lin`` (a
    :class:`~sail_env.physics.rigid3d.linearise.Linearisation`) in ``task`` (a
    :class:`~sail_env.physics.rigid3d.plant.RigidTaskConfig`)."""
    fastest = (1 + parameter_spread) / (1 - parameter_spread) * (1 + task.power_control)
    return lin.push_n / lin.mass_kg * fastest, 2.0 * task.beam_cutoff_s


def farthest_distance_m(task, lin, parameter_spread: float) -> float:
    """The farthest the sail can be from the array at a cut-off (the bound of :func:`fastest_flight`)."""
    accel, horizon = fastest_flight(task, lin, parameter_spread)
    return 0.5 * accel * horizon**2


def check_flight(task, lin, parameter_spread: float) -> None:
    """The flight's settings whose range depends on the sail's push and mass (``lin``) and its task
    (``task``, a :class:`~sail_env.physics.rigid3d.plant.RigidTaskConfig`); the random disturbances
    check their own (:mod:`sail_env.physics.disturbances`)."""
    sail = task.sail
    accel, _ = fastest_flight(task, lin, parameter_spread)
    window_end = task.control_start_s + task.control_window_s
    window_distance = 0.5 * accel * window_end**2
    widest = _bisect(lambda s: sail.caught_fraction(s) >= MIN_CAUGHT_FRACTION, 1.0, 1e6)
    shortest = window_distance / widest
    if not task.diffraction_length_m >= shortest:
        raise ValueError(f"diffraction_length_m must be >= {shortest:.4g} m (inf: no diffraction): the spot, widened "
                         f"by D/L0 up to the control window's end (D <= {window_distance:.4g} m), must still put >= "
                         f"{MIN_CAUGHT_FRACTION:.0%} of the beam on the sail, got {task.diffraction_length_m}")
