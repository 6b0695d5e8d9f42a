"""Shared fixtures: the seed paper's equations written out literally, as an independent reference."""

from __future__ import annotations

import numpy as np
import pytest

from sail_env.physics import SEED, SailConfig


def seed_rhs(config: SailConfig, state: np.ndarray, beam: np.ndarray = np.zeros(2)) -> np.ndarray:
    """Seed eqs 16-19 as in its appendix code, with the beam offset d and tilt ψ entering
    as docs/physics.md §3 says: ``X → X − d``, ``θ → θ − ψ`` inside the curvature terms."""
    x, vx, theta, omega = state
    d, psi = beam
    f, m, lc = config.push_force_n, config.total_mass_kg, config.com_distance_m
    inertia = config.sail_mass_kg * lc**2 + config.craft_mass_kg * (config.strut_length_m - lc) ** 2
    delta = (x - d) + lc * (theta - psi)
    r = config.curvature_radius_m
    if np.isinf(r):
        return np.array([vx, f / m * theta, omega, 0.5 * f / inertia * delta])
    return np.array([vx, f / m * theta - 0.5 * f / m * delta / r,
                     omega, -0.5 * f / inertia * delta * (lc / r - 1)])


@pytest.fixture
def seed_config() -> SailConfig:
    return SEED
