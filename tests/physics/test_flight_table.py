"""The tabled axial flight (sail_env.physics.rigid3d.flight, docs/physics.md §14) against DOP853 at
rtol 1e-13 of the axial law itself, its closed form against Newton's limit, its push law against the
surface quadrature, its fast single-read path against the batched one, and its independence of the
BLAS kernel (the table of two OpenBLAS kernels, bit for bit)."""

from __future__ import annotations

import hashlib
import math
import os
import subprocess
import sys

import numpy as np
import pytest
import scipy.integrate

from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.relativity import diffraction_scale, doppler_push_factor
from sail_env.physics.rigid3d.body import RigidSail, axial_rates
from sail_env.physics.rigid3d.flight import DrawFlights, PushLaw, _hermite, fly

from tests.physics.test_plant3d_diffraction import FASTEST, REALISTIC_SAIL

#: LightSail3DRealistic-v1's beam (a Gaussian of waist 0.8 a) and L0.
GAUSSIAN_SAIL = REALISTIC_SAIL.replace(beam_profile="gaussian", beam_radius_m=1.6)
LENGTH = 1.5465511908444e10
#: A flat-top beam focused inside the rim: beyond L0 its edge meets the rim at s = a/r = 1.25 (a kink).
NARROW_SAIL = REALISTIC_SAIL.replace(beam_radius_m=1.6)


def reference(sail: RigidSail, duration: float, relativistic: bool, length: float, kinks=(1.0,)):
    """The axial law integrated by DOP853 at rtol 1e-13, restarted where the spot reaches each scale
    in ``kinks`` (the push's derivative jumps there): ``(γβ, D)`` at times (t,) as (2, t)."""
    segments, start, state = [], 0.0, [0.0, 0.0]
    for target in [*(length * s for s in kinks), math.inf]:
        event = lambda _t, y, target=target: y[1] - target  # noqa: E731
        event.terminal = True
        solution = scipy.integrate.solve_ivp(
            lambda _t, y: axial_rates(sail, float(y[0]), float(y[1]), length, relativistic), (start, duration),
            state, method="DOP853", rtol=1e-13, atol=1e-30, dense_output=True, events=event)
        segments.append((solution.t[-1], solution.sol))
        start, state = solution.t[-1], solution.y[:, -1]
        if start >= duration:
            break

    def read(times: np.ndarray) -> np.ndarray:
        out = np.empty((2, len(times)))
        for i, t in enumerate(times):
            out[:, i] = next(sol for end, sol in segments if t <= end)(t)
        return out

    return read


@pytest.mark.parametrize("config, relativistic, length", [
    (GAUSSIAN_SAIL, True, LENGTH), (GAUSSIAN_SAIL, False, 0.8 * LENGTH), (GAUSSIAN_SAIL, True, math.inf),
    (NARROW_SAIL, True, 0.8 * LENGTH)])
def test_table_matches_a_tight_integration(config, relativistic, length):
    """Speed, distance, Doppler factor and spot scale within 1e-12 (relative) of DOP853 at rtol 1e-13,
    from the first second to beyond the spot's widening (v1's flight: L0 at ~640 s, s = 1.7 at 1,466 s)."""
    sail = RigidSail(config)
    duration = 1466.0
    flight = fly(sail, duration, relativistic, length)
    times = np.concatenate([np.linspace(1.0, duration, 3001), [0.1, 0.37, 2.2]])
    kinks = (1.0, config.aperture_radius_m / config.outer_beam_radius_m) if config is NARROW_SAIL else (1.0,)
    momentum, distance = reference(sail, duration, relativistic, length, kinks)(times)
    beta = momentum / np.sqrt(1 + momentum**2) if relativistic else momentum
    factor = doppler_push_factor(beta) if relativistic else np.ones_like(beta)
    for got, want in ((flight.speed(times), beta * SPEED_OF_LIGHT), (flight.distance(times), distance),
                      (flight.power_factor(times), factor),
                      (flight.beam_scale(times), diffraction_scale(distance, length))):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    if math.isfinite(length):  # the flight does widen its spot (and lose push) within the table
        assert flight.beam_scale(duration) > 1.3


def test_closed_form_newtonian_limit_and_rest():
    """Without diffraction the table is the closed form: at rest ``D = ½ a t²`` to 1e-12, and Newton's
    flight exactly ``a t`` and ``½ a t²``."""
    sail = RigidSail(GAUSSIAN_SAIL)
    acceleration = sail.centred_push() / sail.mass
    times = np.array([0.3, 1.0, 7.7, 100.0, 599.0])
    newton = fly(sail, 600.0, relativistic=False)
    np.testing.assert_allclose(newton.speed(times), acceleration * times, rtol=1e-14)
    np.testing.assert_allclose(newton.distance(times), 0.5 * acceleration * times**2, rtol=1e-14)
    relativistic = fly(sail, 600.0)
    early = np.array([0.01, 0.1, 0.3])
    # The Doppler law's first correction: D = ½ a t² (1 − (2/3) a t / c), the next term ~(a t / c)² < 1e-8.
    np.testing.assert_allclose(relativistic.distance(early),
                               0.5 * acceleration * early**2 * (1 - 2 / 3 * acceleration * early / SPEED_OF_LIGHT),
                               rtol=1e-8)
    # and a t/c itself is there: Newton's ½ a t² is off by (2/3) a t / c ≈ 6e-5 at 0.3 s.
    assert abs(relativistic.distance(0.3) / (0.5 * acceleration * 0.09) - 1) > 5e-5


def test_push_law_matches_the_quadrature():
    sail = RigidSail(GAUSSIAN_SAIL)
    law = PushLaw(sail, 6.0)
    near = sail.centred_push()
    for scale in (1.0, 1.0003, 1.07, 1.5, 2.345, 5.9):
        assert law.relative(scale) == pytest.approx(sail.centred_push(1.0, scale) / near, rel=1e-13, abs=0)
    # A flat-top of radius r inside the rim: its edge meets the rim at s = a/r, where the law has a kink.
    narrow = PushLaw(RigidSail(NARROW_SAIL), 3.0)
    assert narrow.edges[1] == pytest.approx(math.log(2.0 / 1.6))


def test_single_reads_are_the_batched_ones():
    sail = RigidSail(GAUSSIAN_SAIL)
    flights = DrawFlights(sail, 1200.0, True, LENGTH, FASTEST)
    ratios = np.array([1 / FASTEST, 0.93, 1.0, 1.11, FASTEST])
    for t in (0.2, 10.5, 599.0, 700.0, 980.0):
        for name in ("speed", "distance", "power_factor", "beam_scale"):
            batched = getattr(flights, name)(ratios, np.full(ratios.size, t))
            single = [getattr(flights, name)(np.array([r]), np.array([t]))[0] for r in ratios]
            np.testing.assert_array_equal(single, batched)



def test_compiled_reads_are_numpys_to_the_bit():
    """The compiled read evaluates the interpolation in Python's order of operations (no fused
    multiply-add, no reordering): the same source run by NumPy over the whole batch gives the same
    bits, on uniform nodes, exactly at nodes and at the kinks."""
    table = DrawFlights(RigidSail(GAUSSIAN_SAIL), 1200.0, True, LENGTH, FASTEST).table
    rng = np.random.default_rng(7)
    rows = rng.integers(0, table.times.shape[0], 4000)
    t = rng.uniform(0.0, table.duration_s, rows.size)
    t[:200] = table.times[rows[:200], rng.integers(0, table.times.shape[1] - 1, 200)]
    kinks = table.kink_times[rows[200:400], 0]
    t[200:400] = np.where(kinks <= table.duration_s, kinks, t[200:400])
    index = (t * (1.0 / table.step)).astype(np.int64) + (table.kink_times[rows] <= t[:, None]).sum(axis=1)
    index = np.minimum(index, table.times.shape[1] - 2)
    nodes = table._nodes
    expected = _hermite.py_func(t, nodes[rows, index].T, nodes[rows, index + 1].T)
    for got, want in zip(table.read(rows, t), expected):
        np.testing.assert_array_equal(got, want)
    assert table.read_one(int(rows[5]), float(t[5])) == (expected[0][5], expected[1][5])

def _table_digest() -> str:
    return hashlib.sha256(DrawFlights(RigidSail(GAUSSIAN_SAIL), 1200.0, True, LENGTH, FASTEST).table._nodes
                          .tobytes()).hexdigest()


def test_table_is_the_same_under_another_blas_kernel():
    """The table is built without BLAS: the generic OpenBLAS kernel builds it to the last bit."""
    code = "from tests.physics.test_flight_table import _table_digest; print(_table_digest())"
    env = {**os.environ, "OPENBLAS_CORETYPE": "Prescott"}
    other = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                           cwd=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    assert other.stdout.strip() == _table_digest()
