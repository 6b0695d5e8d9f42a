"""Relativistic acceleration of a perfectly reflecting sail by a laser of power P.

The correct law (lab time ``t``; momentum ``p = γ m β c``; the mirror recedes, so the
reflected light is Doppler shifted and the photon arrival rate drops)::

    d(γβ)/dt = (2P / m c²) · (1 − β)/(1 + β)

as in Kulkarni, Lubin & Zhang 2018 (AJ 155, 155), who write it as
``dβ/dt = (2P/mc²)(1−β)/(1+β)(1−β²)^{3/2}``. With the Doppler factor
``w = √((1−β)/(1+β))`` it integrates in closed form (derived here)::

    t(β) = [1/w + 1/(3 w³) − 4/3] / (2 k),     k = 2P/(m c²).

For comparison, the law without the Doppler loss gives ``γβ = k t``, and the seed
paper's eq 6 (``dβ/dt (1−β²)⁻² = k``, a γ⁴ where momentum gives γ³, and no Doppler)
integrates to its eq 7. Beyond the diffraction distance ``L0 = d D/(2 λ α)`` the power
on the sail falls as ``(L0/L)²`` (Kulkarni et al. 2018); :func:`beta_history` includes it.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from sail_env.physics.constants import SPEED_OF_LIGHT

Law = Literal["doppler", "no_doppler", "seed_eq7"]
LAWS: tuple[Law, ...] = ("doppler", "no_doppler", "seed_eq7")


def _rate(power_w: float, mass_kg: float, reflectance: float = 1.0) -> float:
    """``k = 2ηP/(m c²)`` [1/s]."""
    if not (power_w > 0 and mass_kg > 0 and 0 < reflectance <= 1):
        raise ValueError(
            "power_w and mass_kg must be > 0 and reflectance in (0, 1], "
            f"got {power_w}, {mass_kg}, {reflectance}"
        )
    return 2.0 * reflectance * power_w / (mass_kg * SPEED_OF_LIGHT**2)


def time_to_beta(beta: float, power_w: float, mass_kg: float, law: Law = "doppler",
                 reflectance: float = 1.0) -> float:
    """Lab time [s] to accelerate from rest to speed ``beta·c`` under ``law``."""
    if not 0.0 <= beta < 1.0:
        raise ValueError(f"beta must be in [0, 1), got {beta}")
    k = _rate(power_w, mass_kg, reflectance)
    if law == "doppler":
        w = math.sqrt((1.0 - beta) / (1.0 + beta))
        return (1.0 / w + 1.0 / (3.0 * w**3) - 4.0 / 3.0) / (2.0 * k)
    if law == "no_doppler":
        return beta / math.sqrt(1.0 - beta**2) / k
    if law == "seed_eq7":
        return (beta / (1.0 - beta**2) + 0.5 * math.log((1.0 + beta) / (1.0 - beta))) / (2.0 * k)
    raise ValueError(f"law must be one of {LAWS}, got {law!r}")


def doppler_push_factor(beta: np.ndarray | float) -> np.ndarray | float:
    """``(1 − β)/(1 + β)``: the push on a receding mirror relative to one at rest (lab frame).

    Photons arrive less often and return redshifted; every radiation force on the sail,
    lateral stiffnesses included, scales with it (to leading order in the sail's own
    lateral and rotational speeds).
    """
    return (1.0 - beta) / (1.0 + beta)


def diffraction_scale(distance_m: np.ndarray | float, diffraction_length_m: float) -> np.ndarray | float:
    """How much wider the beam spot is at ``distance_m`` than at ``L0``: ``max(1, D/L0)``.

    Beyond ``L0`` the diffraction-limited spot grows as ``D/L0`` and, its power
    conserved, its intensity falls as ``(L0/D)²``: the power a sail smaller than the
    spot catches falls as ``(L0/D)²`` (Kulkarni, Lubin & Zhang 2018).
    """
    return np.maximum(1.0, np.asarray(distance_m, dtype=float) / diffraction_length_m)


def beta_history(times: np.ndarray, power_w: float, mass_kg: float, law: Law = "doppler",
                 reflectance: float = 1.0, diffraction_length_m: float = math.inf) -> np.ndarray:
    """β at each lab time in ``times`` (ascending, from 0), by numerical integration.

    With a finite ``diffraction_length_m`` the power on the sail is ``P min(1, (L0/L)²)``
    at distance ``L`` flown (Kulkarni et al. 2018).
    """
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size == 0 or times[0] < 0 or np.any(np.diff(times) < 0):
        raise ValueError("times must be a non-empty ascending 1-D array starting at >= 0")
    if not diffraction_length_m > 0:
        raise ValueError(f"diffraction_length_m must be > 0, got {diffraction_length_m}")
    k = _rate(power_w, mass_kg, reflectance)

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        beta, distance = min(y[0], 1.0 - 1e-15), y[1]
        power_share = float(diffraction_scale(distance, diffraction_length_m)) ** -2
        kk = k * power_share
        if law == "doppler":
            dbeta = kk * doppler_push_factor(beta) * (1 - beta**2) ** 1.5
        elif law == "no_doppler":
            dbeta = kk * (1 - beta**2) ** 1.5
        elif law == "seed_eq7":
            dbeta = kk * (1 - beta**2) ** 2
        else:
            raise ValueError(f"law must be one of {LAWS}, got {law!r}")
        return [dbeta, beta * SPEED_OF_LIGHT]

    import scipy.integrate  # here: ~0.3 s to import, and only this reference integration needs it

    sol = scipy.integrate.solve_ivp(rhs, (0.0, float(times[-1])), [0.0, 0.0], t_eval=times,
                                    method="DOP853", rtol=1e-10, atol=1e-14)
    if not sol.success:
        raise RuntimeError(f"integration failed: {sol.message}")
    return sol.y[0]
