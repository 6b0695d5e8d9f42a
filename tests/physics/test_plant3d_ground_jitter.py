"""Beam jitter as a ground angle in the 3D plant (docs/physics.md §12, §14): the spot moves by
``D(t)·δ`` at the sail, in the window and over the coast."""

from __future__ import annotations

import numpy as np

from sail_env.physics.noise import mean_and_covariance, second_moment
from sail_env.physics.rigid3d.plant import RigidTaskConfig, RigidPlant
from sail_env.physics.disturbances import split_keywords
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.analysis.jitter import accumulate_covariance

SIGMA_RAD = 1e-14


def plant_with(**kwargs) -> RigidPlant:
    sources, flight = split_keywords(kwargs)
    return RigidPlant(RigidTaskConfig(RigidSailConfig(absorptivity=0.1, reflectivity=0.9), **flight), disturbances=sources)


def test_step_jitter_is_the_distance_times_the_angle():
    plant = plant_with(ground_jitter_rad=SIGMA_RAD)
    p = plant.params(np.ones((1, 3)))
    t = np.array([10.0, 100.0, 600.0])
    # Newton's flight: D = a t² / 2.
    expected = 0.5 * plant.nominal_acceleration * t**2 * SIGMA_RAD
    np.testing.assert_allclose(plant.jitter_std(p, t)[:, 0], expected, rtol=1e-8)
    faster = plant_with(ground_jitter_rad=SIGMA_RAD, relativistic=True)
    assert np.all(faster.jitter_std(faster.params(np.ones((1, 3))), t)[1:, 0] < expected[1:])


def test_coast_spread_matches_the_covariance_of_the_jitter_analysis():
    """The coast's moments (45×45 generator of the second moments, 5 s pieces at their middle) against
    :func:`jitter.accumulate_covariance` (Van Loan on the 8 states, D² averaged over 0.05 s)."""
    plant = plant_with(ground_jitter_rad=SIGMA_RAD)
    p = plant.params(np.ones((1, 3)))
    start, end = 580.0, 600.0
    u = np.zeros((1, 4))
    pieces = int(plant.coast_pieces(p, np.array([end - start]))[0])
    assert pieces == 4
    piece = (end - start) / pieces
    moment = second_moment(np.zeros((1, 8)), np.zeros((1, 8, 8)))
    middles = start + (np.arange(pieces) + 0.5) * piece
    for propagator in plant._piece_propagators(p, u, middles[None], np.array([piece])):
        moment = np.einsum("kij,kj->ki", propagator, moment)
    mean, cov = mean_and_covariance(moment)
    fine = np.arange(start, end, 0.05) + 0.025
    distance = 0.5 * plant.nominal_acceleration * fine**2
    b = p.b[0]
    shape = np.outer(b[:, 0], b[:, 0]) + np.outer(b[:, 1], b[:, 1])
    reference = accumulate_covariance(((p.a[0], (d * SIGMA_RAD) ** 2 * plant.dt * shape, 0.05) for d in distance), 8)
    np.testing.assert_allclose(mean[0], 0.0, atol=1e-30)
    speed = [2, 3]
    np.testing.assert_allclose(np.diag(cov[0])[speed], np.diag(reference)[speed], rtol=2e-3)
    np.testing.assert_allclose(cov[0], reference, rtol=0, atol=2e-3 * np.abs(reference).max())
    # Holding the distance at the coast's start instead misses the tolerance: the test can fail.
    held = 0.5 * plant.nominal_acceleration * start**2
    fixed = accumulate_covariance(((p.a[0], (held * SIGMA_RAD) ** 2 * plant.dt * shape, 0.05) for _ in distance), 8)
    assert np.all(np.diag(reference)[speed] > 1.03 * np.diag(fixed)[speed])
