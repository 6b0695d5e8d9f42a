"""The validators every sail model's configuration and the episode's settings share: one
``ValueError`` naming the field and its valid range (docs/development.md)."""

from __future__ import annotations

import numbers

import numpy as np

from sail_env.physics.constants import SPEED_OF_LIGHT

#: Most control steps in a window. The episode core draws every normal an episode's window
#: can need at reset (a few per step), so the window's length is memory per environment;
#: 10⁵ steps (500 s at 5 ms) keeps that to a few MB and covers any controllable window.
MAX_CONTROL_STEPS = 100_000


def real_number(value: object, name: str) -> float:
    """``value`` as a float if it is a real number: an int, a float or a NumPy real scalar such as
    ``np.float32(1.0)``; a bool, a string or an array raises ``ValueError`` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    return float(value)


def boolean(value: object, name: str) -> bool:
    """``value`` as a bool if it is ``True``, ``False`` or a NumPy bool; anything else (``0``, ``1``,
    strings) raises ``ValueError`` naming ``name``."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a bool (True or False), got {value!r}")
    return bool(value)


def check_timing(control_start_s: float, control_step_s: float, control_window_s: float,
                 beam_cutoff_s: float) -> None:
    """The control window's timing, as every sail's configuration checks it (the step and the
    cut-off already > 0): it starts at or after launch, holds at least one and at most
    :data:`MAX_CONTROL_STEPS` steps, and ends by the beam's cut-off. ``ValueError`` names the field."""
    if control_start_s < 0:
        raise ValueError(f"control_start_s must be >= 0, got {control_start_s}")
    if control_window_s < control_step_s:
        raise ValueError(f"control_window_s must be >= control_step_s ({control_step_s} s), got {control_window_s}")
    if control_start_s + control_window_s > beam_cutoff_s:
        raise ValueError(f"control_start_s + control_window_s must be <= beam_cutoff_s ({beam_cutoff_s} s), "
                         f"got {control_start_s + control_window_s}")
    steps = control_window_s / control_step_s  # may overflow to inf: compared before rounding
    if not steps <= MAX_CONTROL_STEPS:
        raise ValueError(f"control_window_s / control_step_s must be <= {MAX_CONTROL_STEPS} steps, got "
                         f"{control_window_s} / {control_step_s} = {steps:.6g}")


def check_below_light_speed(acceleration_m_s2: float, t: float, what: str,
                            remedy: str = "push_force_n or beam_cutoff_s") -> None:
    """A Newtonian flight (``Vz = a t``, the planar model's and the light delay's bound): refuse a push
    that would pass the speed of light by ``t`` (naming ``what`` sets the limit and the settings to
    lower, ``remedy``)."""
    speed = acceleration_m_s2 * t
    if not speed < SPEED_OF_LIGHT:
        raise ValueError(
            f"{what}: the Newtonian axial speed a t = {acceleration_m_s2:.4g} m/s² x {t:.4g} s = {speed:.4g} m/s "
            f"at cut-off must stay below the speed of light ({SPEED_OF_LIGHT:.6g} m/s); lower {remedy}")
