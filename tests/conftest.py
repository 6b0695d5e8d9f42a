"""Shared fixtures: the seed paper's equations written out literally, as an independent reference; the
3D tables' disk cache kept to this run (below); and a guard that no test leaves the process's Ctrl-C
handling changed (a handler left behind made a later test's Ctrl-C a stop request, and every
training run after it ended "interrupted")."""

from __future__ import annotations

import atexit
import os
import shutil
import signal
import tempfile

import numpy as np
import pytest

from sail_env.physics import SEED, SailConfig
from sail_env.physics.memo import CACHE_VARIABLE

# The 3D tables' disk cache (sail_env/physics/memo.py) in a directory of this run's own, removed at its
# end: the tests build every table afresh and leave nothing in the user's cache.
os.environ[CACHE_VARIABLE] = tempfile.mkdtemp(prefix="lightsail-gym-tables-")
atexit.register(shutil.rmtree, os.environ[CACHE_VARIABLE], ignore_errors=True)


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


@pytest.fixture(autouse=True)
def _signal_handlers_restored():
    """Fail the test that changes SIGINT's or SIGTERM's handler without putting it back."""
    before = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    yield
    after = {signum: signal.getsignal(signum) for signum in before}
    changed = [signal.Signals(signum).name for signum in before if after[signum] is not before[signum]]
    for signum, handler in before.items():
        signal.signal(signum, handler)
    assert not changed, f"the test left the handler of {', '.join(changed)} changed"
