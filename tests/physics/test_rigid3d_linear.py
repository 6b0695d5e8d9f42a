"""Linearised rigid 3D sail against the planar model, eigen-analysis, the nonlinear model and PHYSICS §7."""

import math

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg

from sail_env.physics import DEEP_DISH, FLAT, SEED, PlanarModel
from sail_env.physics.rigid3d import RigidSail, RigidSailConfig, linearise, state_from_small
from sail_env.physics.rigid3d.body import small_state

# Planar (X, θ) is (x, θy) here; rows v̇x, ω̇y and columns x, θy of A, d_x, ψ_x of B.
X_ROWS, X_COLS, X_INPUTS = [2, 7], [0, 5], [0, 2]


def planar_pairs(config_3d, config_planar):
    lin = linearise(RigidSail(config_3d))
    planar = PlanarModel(config_planar)
    return lin, planar, lin.A[np.ix_(X_ROWS, X_COLS)], planar.A[np.ix_([1, 3], [0, 2])]


def test_seed_limit_reproduces_the_planar_coefficients_and_70_7_rad_per_s():
    lin, planar, a3, ap = planar_pairs(RigidSailConfig(), SEED)
    # Force rows agree to the seed's a²/R² = 4 % (3D: 2.0 % lower lateral stiffness, the cos²
    # law and the exact lens; 4.0 % lower tilt force, the push 2 % lower than 2P/c).
    np.testing.assert_allclose(a3[0], ap[0], rtol=0.05)
    np.testing.assert_allclose(lin.B[2, X_INPUTS], planar.B[1], rtol=0.05)
    # Lc = R: every force passes through the CoM; the torque rows vanish to round-off.
    scale = lin.push_n * SEED.com_distance_m / lin.inertia[1, 1]
    assert np.abs(a3[1]).max() < 1e-9 * scale and np.abs(lin.B[7]).max() < 1e-9 * scale
    assert lin.frequencies[-1] == pytest.approx(70.71, rel=0.02)
    assert planar.stability.frequencies[0] == pytest.approx(70.71, rel=1e-4)


def test_deep_dish_differs_from_the_planar_a_much_less_than_r_formulas_by_tens_of_per_cent():
    lin, planar, a3, ap = planar_pairs(RigidSailConfig(curvature_radius_m=4.0), DEEP_DISH)
    ratio = a3 / ap
    assert np.all(np.abs(ratio - 1) < 0.2) and np.abs(ratio - 1).max() > 0.05
    assert lin.growth_rate < 1e-6
    np.testing.assert_allclose(lin.frequencies, [65.33, 116.63], rtol=1e-3)


def test_x_and_y_axes_are_symmetric():
    for config in (RigidSailConfig(curvature_radius_m=4.0, reflectivity=0.9, absorptivity=0.1), RigidSailConfig(shape="cone"),
                   RigidSailConfig(shape="balloon", beam_profile="multi-gaussian", curvature_radius_m=3.0)):
        lin = linearise(RigidSail(config))
        # The sail is axisymmetric and every beam four-fold symmetric: turning everything by 90°
        # about the beam axis, (x, y) → (−y, x) for each pair, leaves the model unchanged.
        quarter = np.array([[0.0, -1.0], [1.0, 0.0]])
        p, q = np.kron(np.eye(4), quarter), np.kron(np.eye(2), quarter)
        np.testing.assert_allclose(p @ lin.A @ p.T, lin.A, atol=1e-8 * np.abs(lin.A).max())
        np.testing.assert_allclose(p @ lin.B @ q.T, lin.B, atol=1e-8 * np.abs(lin.B).max())
        assert np.abs(lin.A[2, 0]) > 0 and np.abs(lin.B[7, 0]) > 0


def test_flat_sail_is_unstable_in_both_axes_at_the_planar_rate():
    lin, planar, a3, ap = planar_pairs(RigidSailConfig(shape="flat"), FLAT)
    assert lin.growth_rate == pytest.approx(planar.stability.growth_rate, rel=0.01)
    growing = np.sort(lin.eigenvalues.real)[-2:]
    np.testing.assert_allclose(growing, lin.growth_rate, rtol=1e-6)  # one per axis


@pytest.mark.parametrize("radius, unstable", [(15.0, True), (4.0, False), (7.0, False)])
def test_dish_is_stable_only_with_the_centre_of_curvature_between_sail_and_com(radius, unstable):
    lin = linearise(RigidSail(RigidSailConfig(curvature_radius_m=radius)))
    planar = PlanarModel(SEED.replace(curvature_radius_m=radius))
    assert (lin.growth_rate > 1.0) == unstable
    if unstable:
        assert lin.growth_rate == pytest.approx(planar.stability.growth_rate, rel=0.05)


def test_input_matrix_is_degenerate_for_specular_spheres_and_lifted_by_absorption_and_cones():
    # PHYSICS §7: a specular sphere's forces pass through its centre of curvature, so per axis
    # the beam offset and tilt act only through one combination.
    for config in (RigidSailConfig(), RigidSailConfig(curvature_radius_m=4.0),
                   RigidSailConfig(shape="balloon", curvature_radius_m=3.0, beam_profile="gaussian")):
        lin = linearise(RigidSail(config))
        assert lin.input_rank == 2
        sv = lin.input_singular_values()
        assert sv[2] / sv[0] < 1e-8
    for config in (RigidSailConfig(reflectivity=0.9, absorptivity=0.1), RigidSailConfig(shape="cone")):
        lin = linearise(RigidSail(config))
        assert lin.input_rank == 4 and lin.input_condition < 1e4


def test_power_acts_parametrically_through_every_radiation_term():
    sail = RigidSail(RigidSailConfig(curvature_radius_m=4.0))
    base, boosted = linearise(sail), linearise(sail, power_factor=1.1)
    np.testing.assert_allclose(boosted.A, base.A + 0.1 * base.push_sensitivity, rtol=1e-6,
                               atol=1e-9 * np.abs(base.A).max())
    np.testing.assert_allclose(boosted.B, 1.1 * base.B, rtol=1e-6, atol=1e-9 * np.abs(base.B).max())


@pytest.mark.parametrize("spin", [0.0, 300.0])
def test_linearisation_matches_the_nonlinear_model_for_small_motions(spin):
    config = RigidSailConfig(curvature_radius_m=4.0, absorptivity=0.05, reflectivity=0.95,
                             radial_nodes=6, angular_nodes=48)
    sail = RigidSail(config)
    lin = linearise(sail, spin=spin)
    eps = 1e-4
    start = state_from_small(x=0.02 * eps, y=-0.01 * eps, theta_x=eps * 1e-2, theta_y=-0.5e-2 * eps,
                             omega_x=0.3 * eps, spin=spin)
    inputs = np.array([[0.01 * eps, 0.0, 0.0, 0.002 * eps]])
    duration = 0.03

    def rhs(_t, y):
        return sail.rates(y[None], inputs)[0]

    solution = scipy.integrate.solve_ivp(rhs, (0, duration), start[0], method="DOP853", rtol=1e-9, atol=1e-16)
    end_nonlinear = small_state(solution.y[:, -1][None])[0]
    phi, gamma = (scipy.linalg.expm(np.block([[lin.A, lin.B], [np.zeros((4, 12))]]) * duration)[:8, k]
                  for k in (slice(0, 8), slice(8, 12)))
    end_linear = phi @ small_state(start)[0] + gamma @ inputs[0]
    scale = np.abs(end_linear).reshape(4, 2).max(axis=1).repeat(2)
    # Second-order terms are ~eps relative; the 3e-3 margin also covers the |offset| push loss.
    np.testing.assert_array_less(np.abs(end_nonlinear - end_linear), 3e-3 * scale)


def test_spin_couples_the_tilt_axes_at_the_euler_nutation_rate():
    # No torque at Lc = R: the tilt modes are the free symmetric top's, nutating at I_a Ω / I_t.
    sail = RigidSail(RigidSailConfig())
    spin = 50.0
    lin = linearise(sail, spin=spin)
    nutation = sail.inertia[2, 2] * spin / sail.inertia[0, 0]
    assert any(math.isclose(f, nutation, rel_tol=1e-6) for f in lin.frequencies)
