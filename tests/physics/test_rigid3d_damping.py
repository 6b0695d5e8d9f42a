"""Velocity-dependent (v/c) radiation terms against photon kinematics and closed forms (docs/physics.md §13)."""

import math

import numpy as np
import pytest

from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.rigid3d import RigidSail, RigidSailConfig, linearise
from sail_env.physics.rigid3d.damping import (damped_linearisation, element_force_change, mode_damping_rates,
                                              rate_jacobian)
from sail_env.physics.rigid3d.flight import fly
from sail_env.analysis.damping import flight_e_folds
from sail_env.analysis.jitter import matched_sail


def boost(energy, momentum, beta):
    """Lorentz boost of a photon's (E, p) (c = 1) into the frame moving with velocity ``beta``."""
    speed = np.linalg.norm(beta)
    if speed == 0:
        return energy, momentum
    gamma = 1.0 / math.sqrt(1.0 - speed**2)
    unit = beta / speed
    along = momentum @ unit
    return gamma * (energy - beta @ momentum), momentum + ((gamma - 1.0) * along - gamma * speed * energy) * unit


def exact_element_force(normal, direction, beta, reflectivity, absorptivity):
    """Force on a moving element per unit ``I du dv / c``, counted photon by photon in the lab: the
    rate of photons through the moving surface times the lab momentum each leaves there (reflected
    in the element's frame; absorbed energy re-emitted isotropically in that frame)."""
    cos_incidence = normal @ direction
    rate = (direction - beta) @ normal / cos_incidence  # per photon flux through du dv
    energy, momentum = boost(1.0, direction, beta)
    out_energy, out_momentum = boost(energy, momentum - 2.0 * (momentum @ normal) * normal, -beta)
    assert out_energy == pytest.approx(np.linalg.norm(out_momentum))
    reflected = direction - out_momentum
    gamma = 1.0 / math.sqrt(1.0 - beta @ beta)
    absorbed = direction - gamma * beta * energy  # the re-emission carries γβE' in the lab
    return rate * (reflectivity * reflected + absorptivity * absorbed)


def test_element_law_matches_photon_kinematics_to_first_order():
    rng = np.random.default_rng(3)
    for _ in range(20):
        normal = np.array([*rng.normal(0, 0.3, 2), 1.0])
        normal /= np.linalg.norm(normal)
        direction = np.array([*rng.normal(0, 0.05, 2), 1.0])
        direction /= np.linalg.norm(direction)
        beta = rng.normal(0, 1e-6, 3)
        exact = exact_element_force(normal, direction, beta, 0.7, 0.2) \
            - exact_element_force(normal, direction, np.zeros(3), 0.7, 0.2)
        first = element_force_change(np.ones(1), normal[None], direction[None], beta[None], 0.7, 0.2)[0]
        # Second-order terms are ~β² = 1e-12 of the force, ~1e-6 of the change.
        np.testing.assert_allclose(first, exact, rtol=0, atol=1e-5 * np.abs(exact).max())


@pytest.mark.parametrize("radius", [10.0, 4.0])
def test_dish_lateral_damping_is_the_closed_form_through_the_centre_of_curvature(radius):
    """Spherical dish, flat-top beam of its aperture: Fx = −(P/c)(a²/R²)(vx/c), τy = z_C Fx."""
    sail = RigidSail(RigidSailConfig(curvature_radius_m=radius))
    power, a, lc = sail.config.beam_power_w, sail.config.aperture_radius_m, sail.config.com_distance_m
    jac = rate_jacobian(sail)
    force = -(power / SPEED_OF_LIGHT) * (a / radius) ** 2 / SPEED_OF_LIGHT
    assert jac[0, 0] == pytest.approx(force, rel=1e-9) and jac[1, 1] == pytest.approx(force, rel=1e-9)
    assert jac[3, 0] == pytest.approx((lc - radius) * force, rel=1e-9, abs=1e-12 * abs(force) * lc)
    assert jac[0, 3] == pytest.approx(jac[3, 0], rel=1e-9, abs=1e-12 * abs(force) * lc)


def test_flat_mirror_rotation_is_damped_by_the_doppler_difference_across_it():
    """A flat mirror rotating about a diameter: τ = −(P/c) a² ω / c; a lateral translation: nothing."""
    sail = RigidSail(RigidSailConfig(shape="flat"))
    power, a = sail.config.beam_power_w, sail.config.aperture_radius_m
    jac = rate_jacobian(sail)
    assert jac[3, 3] == pytest.approx(-(power / SPEED_OF_LIGHT) * a**2 / SPEED_OF_LIGHT, rel=1e-9)
    assert np.abs(jac[:2, :2]).max() < 1e-12 * abs(jac[3, 3])


def test_aberration_of_a_translating_sail_equals_a_beam_tilt_in_a_beam_wider_than_the_sail():
    """Inside a uniform beam the spot's position does not matter, so moving at v is the beam tilted by
    −v/c (aberration; the Doppler term vanishes for a lateral motion): dF/dv = −(dF/dψ)/c, with dF/dψ
    from finite differences of the static wrench (linearise's B)."""
    for shape, radius in (("dish", 10.0), ("dish", 4.0), ("cone", 4.0)):
        sail = RigidSail(RigidSailConfig(shape=shape, curvature_radius_m=radius, beam_radius_m=3.0))
        tilt = linearise(sail).B[np.ix_([2, 3, 6, 7], [2, 3])] * np.array([sail.mass] * 2 + [sail.inertia[0, 0]] * 2)[:, None]
        np.testing.assert_allclose(rate_jacobian(sail)[:, :2], -tilt / SPEED_OF_LIGHT, rtol=1e-5,
                                   atol=1e-6 * np.abs(tilt).max() / SPEED_OF_LIGHT)


def test_flag_off_is_the_static_model_and_on_changes_only_the_rate_columns():
    sail = RigidSail(RigidSailConfig(curvature_radius_m=4.0, absorptivity=0.1, reflectivity=0.9))
    static = linearise(sail)
    off = damped_linearisation(sail)
    on = damped_linearisation(sail, velocity_terms=True)
    np.testing.assert_array_equal(off.A, static.A)
    changed = on.A - static.A
    assert np.all(changed[:, [0, 1, 4, 5]] == 0) and np.all(changed[[0, 1, 4, 5]] == 0)
    assert np.all(np.abs(np.diag(changed)[[2, 3, 6, 7]]) > 0)
    np.testing.assert_array_equal(on.push_sensitivity - static.push_sensitivity, changed)


def test_seed_lateral_mode_e_folds_over_the_flight_match_the_closed_form():
    """At R = Lc the lateral mode is x alone: decay rate (P/c)(a²/R²)/(2 m c), constant push over 600 s."""
    sail = matched_sail(RigidSailConfig(), 98.0)
    power, a = sail.config.beam_power_w, sail.config.aperture_radius_m
    rate = (power / SPEED_OF_LIGHT) * (a / 10.0) ** 2 / (2.0 * sail.mass * SPEED_OF_LIGHT)
    frequencies, e_folds = flight_e_folds(sail, fly(sail, 600.0, relativistic=False), segment_s=600.0)
    assert frequencies == pytest.approx([69.99], abs=0.01)
    assert e_folds[0] == pytest.approx(600.0 * rate, rel=1e-3)
    assert 1.9e-3 < e_folds[0] < 2.1e-3


def test_mode_damping_rates_of_a_damped_oscillator():
    a = np.array([[0.0, 1.0], [-100.0, -0.2]])  # λ = −0.1 ± i √(100 − 0.01)
    frequencies, decay = mode_damping_rates(a)
    assert frequencies == pytest.approx([math.sqrt(100 - 0.01)]) and decay == pytest.approx([0.1])
