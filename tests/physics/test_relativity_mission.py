import math

import numpy as np
import pytest
import scipy.integrate

from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.mission import (
    distance_flown_m,
    one_way_light_delay_s,
    pointing_tolerance_rad,
    required_figure_of_merit,
    thermal_acceleration_limit,
)
from sail_env.physics.relativity import LAWS, beta_history, time_to_beta

POWER, MASS = 50e9, 1e-3


@pytest.mark.parametrize("law", LAWS)
def test_closed_forms_match_numerical_integration(law):
    for beta in (0.05, 0.2, 0.5):
        t = time_to_beta(beta, POWER, MASS, law)
        assert beta_history(np.array([0.0, t]), POWER, MASS, law)[-1] == pytest.approx(beta, rel=1e-7)


@pytest.mark.parametrize("law", LAWS)
def test_non_relativistic_limit(law):
    beta = 1e-4
    newton = beta * SPEED_OF_LIGHT * MASS / (2 * POWER / SPEED_OF_LIGHT)
    assert time_to_beta(beta, POWER, MASS, law) == pytest.approx(newton, rel=1e-3)


def test_doppler_law_is_tens_of_percent_slower_to_0_2c():
    doppler = time_to_beta(0.2, POWER, MASS, "doppler")
    no_doppler = time_to_beta(0.2, POWER, MASS, "no_doppler")
    seed = time_to_beta(0.2, POWER, MASS, "seed_eq7")
    # Seed eq 7 written out: t = m c²/(4P) [β/(1−β²) + ½ ln((1+β)/(1−β))].
    assert seed == pytest.approx(MASS * SPEED_OF_LIGHT**2 / (4 * POWER) * (0.2 / 0.96 + 0.5 * math.log(1.5)))
    assert no_doppler == pytest.approx(0.2 / math.sqrt(0.96) * MASS * SPEED_OF_LIGHT**2 / (2 * POWER))
    assert 0.15 < doppler / no_doppler - 1 < 0.35
    assert doppler == pytest.approx(226.4, abs=0.5)


def test_doppler_law_in_momentum_form_against_kulkarni_form_and_closed_form():
    """Three forms of one law: d(γβ)/dt = k (1−β)/(1+β) integrated here in the momentum u = γβ;
    Kulkarni, Lubin & Zhang 2018's dβ/dt = k (1−β)(1−β²)^{3/2}/(1+β) (beta_history); and the
    closed form t(β) derived in docs/physics.md §5 (time_to_beta)."""
    k = 2 * POWER / (MASS * SPEED_OF_LIGHT**2)

    def momentum_rhs(_t, u):
        beta = u[0] / math.sqrt(1 + u[0] ** 2)
        return [k * (1 - beta) / (1 + beta)]

    times = np.linspace(0.0, 600.0, 7)
    sol = scipy.integrate.solve_ivp(momentum_rhs, (0, 600.0), [0.0], t_eval=times, method="DOP853",
                                    rtol=1e-12, atol=1e-15)
    beta_momentum = sol.y[0] / np.sqrt(1 + sol.y[0] ** 2)
    np.testing.assert_allclose(beta_history(times, POWER, MASS), beta_momentum, rtol=1e-8, atol=1e-14)
    for t, beta in zip(times[1:], beta_momentum[1:]):
        assert time_to_beta(beta, POWER, MASS) == pytest.approx(t, rel=1e-8)
    # The closed form's derivative is Kulkarni's rate, inverted.
    for beta in (0.01, 0.2, 0.6):
        h = 1e-6
        slope = (time_to_beta(beta + h, POWER, MASS) - time_to_beta(beta - h, POWER, MASS)) / (2 * h)
        assert 1 / slope == pytest.approx(k * (1 - beta) * (1 - beta**2) ** 1.5 / (1 + beta), rel=1e-7)


def test_diffraction_falloff_is_inverse_square():
    """Newtonian limit: beyond L0 the push falls as (L0/L)², so ½v² = ½v0² + a L0²(1/L0 − 1/L) (an
    inverted gravity well) and the speed tends to √2 times the speed v0 at L0; an (L0/L)¹ falloff
    would grow without bound as √(1 + ln(L/L0))."""
    power, l0 = 1e3, 1e6  # β ~ 1e-7: relativity is far below the tolerance
    accel = 2 * power / (MASS * SPEED_OF_LIGHT)
    t0 = math.sqrt(2 * l0 / accel)  # reaches L0 at constant acceleration
    beta = beta_history(np.array([0.0, t0, 2000 * t0]), power, MASS, diffraction_length_m=l0)
    assert beta[1] * SPEED_OF_LIGHT == pytest.approx(accel * t0, rel=1e-6)
    # At 2000 t0 the sail is ≥ 2800 L0 out: √(2 − L0/L) within 2e-4 of √2.
    assert beta[2] / beta[1] == pytest.approx(math.sqrt(2), rel=5e-4)


def test_diffraction_slows_the_sail_beyond_l0():
    times = np.linspace(0, 300, 7)
    free = beta_history(times, POWER, MASS)
    limited = beta_history(times, POWER, MASS, diffraction_length_m=1e9)
    assert limited[-1] < free[-1]
    np.testing.assert_allclose(limited[:2], free[:2], rtol=1e-6)  # before L0 nothing changes


def test_bad_relativity_input():
    with pytest.raises(ValueError, match="beta"):
        time_to_beta(1.0, POWER, MASS)
    with pytest.raises(ValueError, match="law"):
        time_to_beta(0.1, POWER, MASS, "galilean")
    with pytest.raises(ValueError, match="mass_kg"):
        time_to_beta(0.1, POWER, -1.0)


def test_seed_mission_numbers():
    # Eq 20: 4e8 m over 4.25 ly ≈ 1e-8 rad.
    assert pointing_tolerance_rad(4e8) == pytest.approx(1e-8, rel=0.01)
    # Eq 24: a = 1e5 m/s², ρd = 5e-5 kg/m², T = 1000 K → εη/α ≥ 6.6e3.
    assert required_figure_of_merit(1e5, 1000.0, 5e-5) == pytest.approx(6.6e3, rel=0.01)
    # Eq 4 inverts eq 24.
    fom = required_figure_of_merit(1e5, 1000.0, 5e-5)
    assert thermal_acceleration_limit(1.0, 1.0, 1.0 / fom, 1000.0, 5e-5) == pytest.approx(1e5)
    # The seed's aluminium (ε 0.06, η 0.82, α 0.135, 600 K): 1.32 m/s² at 10 nm (2.71e-5 kg/m²).
    assert thermal_acceleration_limit(0.06, 0.82, 0.135, 600.0, 2.71e-5) == pytest.approx(1.32, rel=0.01)
    # Distance at cut-off 1.8e7 km (the seed §3.4 says ~1e7 km); round trip ≈ 2 min (docs/physics.md §3).
    assert distance_flown_m(1e5, 600.0) == pytest.approx(1.8e10)
    assert 2 * one_way_light_delay_s(1e5, 600.0) == pytest.approx(120.0, rel=0.01)
    with pytest.raises(ValueError, match="absorptance"):
        thermal_acceleration_limit(0.1, 0.9, 0.0, 600.0, 1e-5)
