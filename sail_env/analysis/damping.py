"""The v/c damping over a whole flight (docs/physics.md §13): a study of the modes' e-folds, off
the runtime path (the plant takes its damping from :mod:`sail_env.physics.rigid3d.damping`)."""

from __future__ import annotations

import math

import numpy as np

from sail_env.physics.rigid3d.body import RigidSail
from sail_env.physics.rigid3d.damping import damped_linearisation, mode_damping_rates
from sail_env.physics.rigid3d.flight import Flight


def flight_e_folds(sail: RigidSail, flight: Flight, segment_s: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """``(frequencies at the start, e-folds)`` of each oscillating mode's amplitude over the flight:
    ``∫ decay rate dt`` with the damping and stiffness at each segment's mid-time (the Doppler
    factor and spot widening of ``flight``)."""
    edges = np.linspace(0.0, flight.duration_s, max(1, math.ceil(flight.duration_s / segment_s)) + 1)
    total, first = None, None
    for lo, hi in zip(edges[:-1], edges[1:]):
        mid = 0.5 * (lo + hi)
        lin = damped_linearisation(sail, power_factor=float(flight.power_factor(mid)),
                                   beam_scale=float(flight.beam_scale(mid)), velocity_terms=True)
        frequencies, decay = mode_damping_rates(lin.A)
        first = frequencies if first is None else first
        if frequencies.size != first.size:
            raise ValueError(f"the oscillating modes change along the flight (at {mid:.0f} s): e-folds undefined")
        total = decay * (hi - lo) if total is None else total + decay * (hi - lo)
    return first, total
