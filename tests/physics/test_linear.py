"""Batched linear algebra against scipy's expm, closed forms and sample statistics."""

import numpy as np
import pytest
import scipy.linalg

from sail_env.physics import DEEP_DISH, SEED, PlanarModel
from sail_env.physics.linear import push_expansion, sample_gaussian, zoh_discretize
from sail_env.physics.planar import push_sensitivity, rates, system_matrices
from sail_env.physics.rigid3d import RigidSail, RigidSailConfig, linearise


def test_batched_discretisation_equals_one_at_a_time():
    models = [PlanarModel(c) for c in (SEED, DEEP_DISH, SEED.replace(curvature_radius_m=15.0))]
    a = np.stack([m.A for m in models])
    b = np.stack([m.B for m in models])
    dts = np.array([0.005, 0.37, 2.0])
    phi, gamma = zoh_discretize(a, b, dts)
    for k, model in enumerate(models):
        aug = np.zeros((6, 6))
        aug[:4, :4], aug[:4, 4:] = model.A, model.B
        exact = scipy.linalg.expm(aug * dts[k])
        np.testing.assert_allclose(phi[k], exact[:4, :4], rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(gamma[k], exact[:4, 4:], rtol=1e-12, atol=1e-14)
    with pytest.raises(ValueError, match="dt"):
        zoh_discretize(a, b, -1.0)


@pytest.mark.parametrize("config", [SEED, DEEP_DISH])
def test_push_expansion_matches_expm_to_third_order(config):
    model = PlanarModel(config)
    a_push, b_push = push_sensitivity(model.A, model.B)
    dt = config.control_step_s
    coeffs = push_expansion(model.A, model.B, a_push, b_push, dt)
    errors = []
    for eps in (1e-3, 1e-2, 4e-2):
        phi, gamma = zoh_discretize(model.A + eps * a_push, (1 + eps) * model.B, dt)
        exact = np.hstack([phi, gamma])
        approx = coeffs[0] + eps * coeffs[1] + eps**2 * coeffs[2]
        errors.append(np.abs(approx - exact).max() / np.abs(exact).max())
    # The error is the third-order remainder: ×1000 per ×10 in ε, and tiny at 1 %.
    assert errors[1] < 1e-7 and errors[0] < 1e-10
    assert errors[2] / errors[1] == pytest.approx(64, rel=0.2)
    # Zero noise is the exact step.
    phi, gamma = model.discretize(dt)
    np.testing.assert_allclose(coeffs[0], np.hstack([phi, gamma]), rtol=1e-13, atol=1e-15)


def test_sampling_reproduces_the_covariance_at_any_scale():
    rng = np.random.default_rng(3)
    base = np.array([[2.0, 0.5, 0, 0], [0.5, 1.0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1e-6]])
    scales = np.array([1e-12, 1e12, 1.0, 1e-3])  # 24 orders of magnitude between components
    for cov in (base, base * np.outer(scales, scales)):
        draws = sample_gaussian(np.zeros(4), cov, rng.standard_normal((20_000, 4)))
        std = np.sqrt(np.diag(cov))
        safe = np.where(std > 0, std, 1.0)
        np.testing.assert_allclose(np.cov(draws.T) / np.outer(safe, safe), cov / np.outer(safe, safe), atol=0.05)
        assert np.all(draws[:, 2] == 0.0)  # zero variance: exactly the mean


def test_sampling_a_rank_one_covariance_of_huge_size():
    # A covariance an unstable coast can produce: rank one, entries near 1e300.
    v = np.array([1e150, 3e149, -2e148, 1e140])
    cov = np.outer(v, v)
    draw = sample_gaussian(np.ones(4), cov, np.ones(4))
    assert np.all(np.isfinite(draw))
    # The draw lies on the line the covariance allows.
    offset = draw - 1.0
    direction = offset / offset[np.argmax(np.abs(offset))]
    np.testing.assert_allclose(direction, v / v[0], rtol=1e-9)


def test_batched_rates_match_the_scalar_stability():
    configs = [SEED, DEEP_DISH, SEED.replace(curvature_radius_m=15.0), SEED.replace(curvature_radius_m=np.inf),
               SEED.replace(curvature_radius_m=7.0, strut_length_m=19.0)]
    params = [(c.push_force_n, c.total_mass_kg, c.moment_of_inertia_kg_m2, c.com_distance_m, c.curvature_radius_m)
              for c in configs]
    a, _ = system_matrices(*np.array(params).T)
    growth, freqs = rates(a)
    for k, config in enumerate(configs):
        stability = PlanarModel(config).stability
        np.testing.assert_array_equal(a[k], PlanarModel(config).A)
        assert growth[k] == pytest.approx(stability.growth_rate, rel=1e-12, abs=0)
        assert sorted(freqs[k][~np.isnan(freqs[k])]) == pytest.approx(list(stability.frequencies), rel=1e-12)


@pytest.mark.parametrize("radius", [10.0, 4.0])
def test_fourth_order_push_expansion_is_exact_for_a_ten_percent_power_command(radius):
    """The 3D power input: [Φ, Γ] of ``K + (1 + ε) A_rad``, ``(1 + ε) B`` at ε = ±0.1 from the
    fourth-order expansion against the matrix exponential itself (second order: ~1e-6)."""
    lin = linearise(RigidSail(RigidSailConfig(curvature_radius_m=radius)))
    kinematics = lin.A - lin.push_sensitivity
    coeffs = {order: push_expansion(lin.A, lin.B, lin.push_sensitivity, lin.B, 0.005, order) for order in (2, 4)}
    for eps in (0.1, -0.1):
        phi, gamma = zoh_discretize(kinematics + (1 + eps) * lin.push_sensitivity, (1 + eps) * lin.B, 0.005)
        exact = np.concatenate([phi, gamma], axis=1)
        error = {order: np.abs(sum(eps**k * c[k] for k in range(order + 1)) - exact).max() / np.abs(exact).max()
                 for order, c in coeffs.items()}
        assert error[4] < 1e-12 and 1e-8 < error[2] < 1e-5
