"""Batched linear algebra against scipy's expm, closed forms and sample statistics."""

import numpy as np
import pytest
import scipy.linalg

from sail_env.physics import DEEP_DISH, SEED, PlanarModel
from sail_env.physics import linear
from sail_env.physics.linear import push_expansion, sample_gaussian, symmetric_root, zoh_discretize
from sail_env.physics.planar.model import push_sensitivity, rates, system_matrices
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


def _covariances(rng: np.random.Generator, count: int, rank: int | None) -> list[np.ndarray]:
    """Random covariances of 8 states, half with the 3D task's structure (two identical lateral
    axes: every eigenvalue double, the eigensolver free to rotate inside each eigenspace), half
    without; of full rank or of ``rank`` (singular); components scaled over 24 orders."""
    out = []
    for k in range(count):
        if k % 2:
            factor = rng.standard_normal((4, rank // 2 if rank else 4))
            cov = np.kron(factor @ factor.T, np.eye(2))  # state order (x, y, vx, vy, …)
        else:
            factor = rng.standard_normal((8, rank or 8))
            cov = factor @ factor.T
        scale = 10.0 ** rng.uniform(-12, 12, 8)
        out.append(cov * np.outer(scale, scale))
    return out


def _perturbed(rng: np.random.Generator, cov: np.ndarray, size: float) -> np.ndarray:
    """``cov`` plus a random symmetric perturbation of ``size`` relative to its correlation scale."""
    noise = rng.standard_normal(cov.shape)
    std = np.sqrt(np.diag(cov))
    return cov + size * (noise + noise.T) / 2 * np.outer(std, std)


@pytest.mark.parametrize("rank, bound", [(None, 1e-10), (4, 1e-6)])
def test_a_draw_is_continuous_in_the_covariance(rank, bound):
    """Round-off in a covariance (1e-15 of its scale) moves a draw by round-off, not by the
    eigensolver's choice of eigenvectors (``V √Λ ξ`` moved by up to 5 σ here). A singular covariance's
    square root is only Hölder-continuous (exponent ½): hence the looser bound."""
    rng = np.random.default_rng(17)
    worst = 0.0
    for cov in _covariances(rng, 200, rank):
        normals = rng.standard_normal(8)
        std = np.sqrt(np.diag(cov))
        moved = sample_gaussian(np.zeros(8), _perturbed(rng, cov, 1e-15), normals) - sample_gaussian(
            np.zeros(8), cov, normals)
        worst = max(worst, float(np.max(np.abs(moved) / std)))
    assert worst < bound


def test_a_draw_does_not_depend_on_the_eigensolver(monkeypatch):
    """numpy's ``eigh`` and every scipy driver give the same draw, to round-off."""
    rng = np.random.default_rng(5)
    covs = _covariances(rng, 40, None) + _covariances(rng, 40, 4)
    normals = rng.standard_normal((len(covs), 8))
    batch = np.stack(covs)
    std = np.sqrt(np.diagonal(batch, axis1=-2, axis2=-1))
    reference = sample_gaussian(np.zeros(8), batch, normals)
    for driver in ("ev", "evd", "evr", "evx"):
        def scipy_eigh(matrices, driver=driver):
            pairs = [scipy.linalg.eigh(m, driver=driver) for m in matrices.reshape(-1, 8, 8)]
            return (np.stack([w for w, _ in pairs]).reshape(matrices.shape[:-1]),
                    np.stack([v for _, v in pairs]).reshape(matrices.shape))
        monkeypatch.setattr(linear.np.linalg, "eigh", scipy_eigh)
        drawn = sample_gaussian(np.zeros(8), batch, normals)
        monkeypatch.undo()
        full_rank = np.arange(len(covs)) < 40
        difference = np.abs(drawn - reference) / std
        assert difference[full_rank].max() < 1e-10, driver
        assert difference[~full_rank].max() < 1e-6, driver


def test_the_symmetric_root_is_a_square_root():
    rng = np.random.default_rng(8)
    for cov in _covariances(rng, 10, None) + _covariances(rng, 10, 4):
        std = np.sqrt(np.diag(cov))
        corr = cov / np.outer(std, std)
        root = symmetric_root(corr)
        np.testing.assert_allclose(root, root.T, atol=1e-13)
        np.testing.assert_allclose(root @ root, corr, atol=1e-12)
        assert np.linalg.eigvalsh(root).min() > -1e-7  # positive semi-definite


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
