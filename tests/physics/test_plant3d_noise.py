"""Push noise in the 3D plant's coast: the spread grows by parametric excitation, and the coast is cut
into pieces by that growth (docs/physics.md §4), as the planar plant's."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from sail_env.physics import linear_plant as plant_module
from sail_env.physics.planar.config import DEEP_DISH
from sail_env.physics.linear import mode_rates
from sail_env.physics.noise import mean_and_covariance, moment_propagator, second_moment, vec_moment_generator
from sail_env.physics.rigid3d.plant import RigidTaskConfig, RigidPlant
from sail_env.physics.rigid3d.config import RigidSailConfig


def stiff_noisy_plant() -> RigidPlant:
    """The deep dish (modes of 64 and 110 rad/s) with the strongest push noise a task allows."""
    return RigidPlant(RigidTaskConfig(RigidSailConfig(curvature_radius_m=DEEP_DISH.curvature_radius_m)), push_noise=0.25)


def test_the_spread_growth_splits_the_coast():
    """The noise-free sail only oscillates; the push noise makes its spread grow at half the full
    moment generator's spectral abscissa (~1/s): 589 s are cut into pieces of e^20."""
    plant = stiff_noisy_plant()
    p = plant.params(np.ones((1, 3)))
    noise_free, _ = mode_rates(p.a)
    full = vec_moment_generator(p.a[0], p.b[0], np.zeros(4), plant.white_noise, (plant.radiation, p.b[0]), (0, 1))
    expected = 0.5 * np.linalg.eigvals(full).real.max()
    assert noise_free[0] < 1e-6 and expected > 0.5
    assert p.growth[0] == pytest.approx(expected, rel=1e-6)
    pieces = plant.coast_pieces(p, np.array([589.0]))
    assert pieces[0] == np.ceil(589.0 * expected / plant_module.GROWTH_PER_PIECE) > 30


def test_a_coast_in_pieces_draws_the_exact_moments(monkeypatch):
    """Each piece draws from the Gaussian of its exact moments given the last draw, so the end's mean
    and second moment are those of one propagation over the whole coast (the tower rule; only higher
    moments feel the Gaussian closure). Two pieces of e^1, averaged exactly over the draws: the end
    state is affine in the second piece's normals and its conditional second moment quadratic in the
    first's, so the 16 points ±√8 eᵢ per piece (weights 1/16) integrate both exactly."""
    monkeypatch.setattr(plant_module, "GROWTH_PER_PIECE", 1.0)
    plant = stiff_noisy_plant()
    p = plant.params(np.ones((1, 3)))
    n = plant.n_states
    duration = 1.5 / p.growth[0]
    assert plant.coast_pieces(p, np.array([duration]))[0] == 2
    points = np.sqrt(n) * np.concatenate([np.eye(n), -np.eye(n)])
    normals = np.stack(np.broadcast_arrays(points[:, None], points[None, :]), axis=2).reshape(-1, 2, n)
    k = len(normals)
    start = np.array([1e-6, -2e-6, 1e-5, 0.0, 1e-7, 0.0, 0.0, 3e-6])
    end, diverged = plant.coast(p, np.tile(start, (k, 1)), np.zeros((k, 4)), np.full(k, duration), normals,
                                np.zeros(k))
    assert not diverged.any()
    generator = plant._moment_generator(p, np.zeros((1, 4)), np.zeros(1))
    propagator = moment_propagator(generator, np.array([duration]), plant.start_limits())
    mean, cov = mean_and_covariance(propagator[0] @ second_moment(start, np.zeros((n, n))))
    second = cov + np.outer(mean, mean)
    assert np.all(np.diag(cov) > mean**2)  # the noise matters
    scale = np.sqrt(np.outer(np.diag(second), np.diag(second)))
    np.testing.assert_allclose(end.mean(axis=0) / np.sqrt(np.diag(second)), mean / np.sqrt(np.diag(second)),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose((end.T @ end / k) / scale, second / scale, rtol=0, atol=1e-9)


def test_a_coast_whose_spread_outgrows_the_beam_ends_as_diverged_without_overflow():
    """589 s at ~1/s grow the spread by e^600: in one piece the second moments overflowed (then
    ``LinAlgError``); in pieces of e^20 the sail leaves the beam within a few and stops there."""
    plant = stiff_noisy_plant()
    p = plant.params(np.ones((1, 3)))
    k = 5
    pieces = int(plant.coast_pieces(p, np.array([589.0]))[0])
    normals = np.random.default_rng(1).standard_normal((k, pieces, plant.n_states))
    start = np.tile([1e-3, 0, 0, 0, 0, 0, 0, 0], (k, 1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        end, diverged = plant.coast(p, start, np.zeros((k, 4)), np.full(k, 589.0), normals, np.zeros(k))
    assert diverged.all() and np.all(np.isfinite(end))
