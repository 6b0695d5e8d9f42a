import math

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from sail_env.physics import DEEP_DISH, FLAT, SEED, PlanarModel, SailConfig, StabilityKind
from sail_env.physics.linear import DISCRETIZE_CACHE_SIZE
from tests.conftest import seed_rhs


def test_matrices_match_the_seed_equations():
    rng = np.random.default_rng(1)
    for config in (SEED, DEEP_DISH, FLAT, SEED.replace(curvature_radius_m=15.0)):
        model = PlanarModel(config)
        for _ in range(5):
            state = rng.normal(size=4) * [1e-2, 1.0, 1e-3, 0.1]
            beam = rng.normal(size=2) * [1e-2, 1e-3]
            np.testing.assert_allclose(model.A @ state + model.B @ beam, seed_rhs(config, state, beam),
                                       rtol=1e-12, atol=1e-12)


def test_seed_eigenvalues_are_pm_70_71i_and_a_double_zero():
    stability = PlanarModel(SEED).stability
    omega = math.sqrt(0.5 * 100.0 / (1e-3 * 10.0))  # sqrt(F / (2 m R))
    assert omega == pytest.approx(70.71, abs=5e-3)
    np.testing.assert_allclose(sorted(stability.eigenvalues.imag), [-omega, 0, 0, omega], atol=1e-9)
    np.testing.assert_allclose(stability.eigenvalues.real, 0, atol=1e-12)
    assert stability.kind is StabilityKind.NEUTRAL
    # Independent: numpy's general eigensolver on A.
    np.testing.assert_allclose(sorted(np.abs(np.linalg.eigvals(PlanarModel(SEED).A))),
                               [0, 0, omega, omega], atol=1e-5)


def test_flat_sail_is_unstable_at_100_per_second():
    stability = PlanarModel(FLAT).stability
    assert stability.kind is StabilityKind.UNSTABLE
    assert stability.growth_rate == pytest.approx(100.0, rel=1e-12)
    assert max(np.linalg.eigvals(PlanarModel(FLAT).A).real) == pytest.approx(100.0, rel=1e-9)


def test_com_between_sail_and_centre_of_curvature_is_exponentially_unstable():
    model = PlanarModel(SEED.replace(curvature_radius_m=15.0))
    assert model.stability.kind is StabilityKind.UNSTABLE
    assert model.stability.growth_rate == pytest.approx(57.735, abs=1e-3)
    assert max(np.linalg.eigvals(model.A).real) == pytest.approx(model.stability.growth_rate, rel=1e-9)


def test_deep_dish_has_two_undamped_oscillations():
    stability = PlanarModel(DEEP_DISH).stability
    assert stability.kind is StabilityKind.OSCILLATION
    assert len(stability.frequencies) == 2
    # Independent: the stiffness of the seed equations (docs/physics.md §1) for q = (X, θ), by hand,
    # F = 100 N, m = 1 g, R = 4 m, Lc = 10 m, I = 0.1 kg m²: K = [[12500, 25000], [750, 7500]],
    # ω² = (tr ± √(tr² − 4 det))/2 = (20000 ± 10000)/2.
    f, m, r, lc, inertia = 100.0, 1e-3, 4.0, 10.0, 0.1
    k = np.array([[f / (2 * m * r), -f / m + f * lc / (2 * m * r)],
                  [f * (lc / r - 1) / (2 * inertia), f * (lc / r - 1) * lc / (2 * inertia)]])
    trace, det = np.trace(k), k[0, 0] * k[1, 1] - k[0, 1] * k[1, 0]
    omegas = np.sqrt([(trace - math.sqrt(trace**2 - 4 * det)) / 2, (trace + math.sqrt(trace**2 - 4 * det)) / 2])
    np.testing.assert_allclose(omegas, [math.sqrt(5000), math.sqrt(15000)], rtol=1e-15)
    assert omegas == pytest.approx([70.7, 122.5], abs=0.05)
    np.testing.assert_allclose(stability.frequencies, omegas, rtol=1e-12)
    np.testing.assert_allclose(sorted(np.abs(np.linalg.eigvals(PlanarModel(DEEP_DISH).A).imag))[::2],
                               stability.frequencies, rtol=1e-9)


@pytest.mark.parametrize("ratio, kind", [(0.3, StabilityKind.OSCILLATION), (0.7, StabilityKind.OSCILLATION),
                                         (1.0, StabilityKind.NEUTRAL), (1.2, StabilityKind.UNSTABLE),
                                         (3.0, StabilityKind.UNSTABLE)])
def test_stability_map_over_r_over_lc(ratio, kind):
    model = PlanarModel(SEED.replace(curvature_radius_m=ratio * SEED.com_distance_m))
    assert model.stability.kind is kind
    # Never damped: no eigenvalue has a negative real part without its mirror image.
    eig = np.linalg.eigvals(model.A)
    assert max(eig.real) >= -1e-9


def test_tilt_is_uncontrollable_when_lc_equals_r():
    model = PlanarModel(SEED)
    assert model.controllable_basis.shape[1] == 2
    assert not model.is_controllable
    # The controllable subspace is (X, Vx): θ and ω are untouched by any beam input.
    np.testing.assert_allclose(model.controllable_basis[[2, 3]], 0, atol=1e-12)
    np.testing.assert_array_equal(model.A[3], 0)
    np.testing.assert_array_equal(model.B[3], 0)
    assert PlanarModel(DEEP_DISH).is_controllable


def test_beam_offset_and_tilt_act_through_the_landing_point():
    """Each column of B against the seed equations written out (tests/conftest.py): a unit offset and
    a unit tilt; the tilt's column is Lc times the offset's (docs/physics.md §1)."""
    model = PlanarModel(DEEP_DISH)
    lc = DEEP_DISH.com_distance_m
    state = np.array([1e-3, 0.0, 2e-4, 0.0])
    for column, beam in enumerate(([1.0, 0.0], [0.0, 1.0])):
        seed_column = seed_rhs(DEEP_DISH, state, np.array(beam)) - seed_rhs(DEEP_DISH, state)
        np.testing.assert_allclose(model.B[:, column], seed_column, rtol=1e-12)
    # By hand: F/(2 m R) = 12,500 and F (Lc/R − 1)/(2 I) = 750 per metre of offset.
    np.testing.assert_allclose(model.B[:, 0], [0, 12_500, 0, 750], rtol=1e-12)
    np.testing.assert_allclose(model.B[:, 1], [0, 12_500 * lc, 0, 750 * lc], rtol=1e-12)
    assert np.linalg.matrix_rank(model.B) == 1


def test_exact_propagation_matches_solve_ivp():
    for config in (SEED, DEEP_DISH, FLAT):
        model = PlanarModel(config)
        state = np.array([1e-3, 0.05, 2e-4, 1e-3])
        beam = np.array([2e-3, -1e-4])
        dt = 0.137
        phi, gamma = model.discretize(dt)
        sol = scipy.integrate.solve_ivp(lambda t, s: seed_rhs(config, s, beam), (0, dt), state,
                                        method="DOP853", rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(phi @ state + gamma @ beam, sol.y[:, -1], rtol=1e-9, atol=1e-14)


def test_seed_figure5_amplitudes():
    """Seed Fig 5: (X, θ) = (1e-5 m, 1e-3 rad) oscillates between 1e-5 m and ~2 cm; (1e-6, 1e-4) ~2 mm."""
    model = PlanarModel(SEED)
    phi, _ = model.discretize(1e-3)
    for x0, theta0, top in ((1e-5, 1e-3, 0.02), (1e-6, 1e-4, 0.002)):
        state = np.array([x0, 0.0, theta0, 0.0])
        xs = [x0]
        for _ in range(200):  # two periods
            state = phi @ state
            xs.append(state[0])
        assert min(xs) == pytest.approx(x0, rel=1e-9)
        assert max(xs) == pytest.approx(top, rel=0.01)
        # Analytic: X oscillates about X_eq = θ (2R − Lc) with amplitude |X0 − X_eq|.
        x_eq = theta0 * (2 * SEED.curvature_radius_m - SEED.com_distance_m)
        assert max(xs) == pytest.approx(2 * x_eq - x0, rel=1e-3)  # 1 ms sampling of an 89 ms period


def test_discretize_rejects_negative_step():
    with pytest.raises(ValueError, match="dt"):
        PlanarModel(SEED).discretize(-1.0)


configs = st.builds(
    SailConfig,
    aperture_radius_m=st.floats(0.1, 5.0),
    curvature_radius_m=st.one_of(st.just(math.inf), st.floats(5.0, 100.0)),
    com_distance_m=st.floats(0.5, 20.0),
    strut_length_m=st.just(40.0),
    sail_mass_kg=st.floats(1e-5, 1e-2),
    craft_mass_kg=st.floats(1e-5, 1e-2),
    push_force_n=st.floats(1.0, 1e3),
    beam_cutoff_s=st.just(1.0),  # up to 5e7 m/s² would pass the speed of light in 600 s
)


@settings(max_examples=60, deadline=None)
@given(configs)
def test_random_valid_configurations_stay_finite(config):
    model = PlanarModel(config)
    assert np.all(np.isfinite(model.A)) and np.all(np.isfinite(model.B))
    stability = model.stability
    assert np.all(np.isfinite(stability.eigenvalues)) and stability.growth_rate >= 0
    eig = np.linalg.eigvals(model.A)
    assert max(eig.real) == pytest.approx(stability.growth_rate, rel=1e-6, abs=1e-6 * max(1, abs(eig).max()))
    phi, gamma = model.discretize(config.control_step_s)
    assert np.all(np.isfinite(phi)) and np.all(np.isfinite(gamma))


def test_frequency_crossing_is_not_reported_as_growth():
    """At R = 2 Lc / 3 (L = 2 Lc) the two modes share one frequency; no flutter (discriminant ≥ 0)."""
    model = PlanarModel(SEED.replace(curvature_radius_m=20.0 / 3.0))
    stability = model.stability
    assert stability.kind is StabilityKind.OSCILLATION and stability.growth_rate == 0.0
    np.testing.assert_allclose(stability.frequencies, [70.7107] * 2, rtol=1e-5)


def test_a_shorter_strut_near_the_crossing_flutters():
    config = SEED.replace(curvature_radius_m=6.75, strut_length_m=19.0)
    stability = PlanarModel(config).stability
    assert stability.kind is StabilityKind.UNSTABLE
    eig = np.linalg.eigvals(PlanarModel(config).A)
    assert stability.growth_rate == pytest.approx(max(eig.real), rel=1e-6)
    assert np.all(np.abs(eig.imag) > 0)  # a growing oscillation, not a divergence


def test_discretize_cache_is_exact_read_only_and_bounded():
    model = PlanarModel(DEEP_DISH)
    durations = [0.005 * k for k in range(1, DISCRETIZE_CACHE_SIZE + 3)]
    for dt in durations:
        phi, gamma = model.discretize(dt)
        reference = scipy.linalg.expm(np.block([[model.A, model.B], [np.zeros((2, 6))]]) * dt)
        np.testing.assert_array_equal(phi, reference[:4, :4])
        np.testing.assert_array_equal(gamma, reference[:4, 4:])
        with pytest.raises(ValueError):
            phi[0, 0] = 1.0
    assert model.discretize(durations[-1])[0] is model.discretize(durations[-1])[0]
    assert len(model._discretized) == DISCRETIZE_CACHE_SIZE
