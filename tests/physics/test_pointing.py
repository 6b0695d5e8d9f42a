import math

import numpy as np
import pytest

from sail_env.analysis.planar import EnvelopeEstimator
from sail_env.physics import DEEP_DISH, SEED, PlanarModel, pointing_error
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD


def _passive_seed(state0):
    model = PlanarModel(SEED)
    phi, _ = model.discretize(SEED.beam_cutoff_s)
    return model, phi @ np.asarray(state0, dtype=float)


def test_passive_seed_sail_pointing_at_cutoff():
    """docs/physics.md §2: from θ0 = 1e-3 rad the passive seed sail ends at ≈ 8.5e-9 rad at 600 s."""
    model, final = _passive_seed([1e-5, 0, 1e-3, 0])
    vz = model.equilibrium_speed(600.0)
    assert vz == pytest.approx(6e7)
    # Analytic: X − X_eq = (X0 − X_eq) cos ωt, so Vx = −ω (X0 − X_eq) sin ωt.
    omega, x_eq = math.sqrt(0.5 * 100 / (1e-3 * 10)), 1e-3 * 10.0
    analytic = abs(omega * (1e-5 - x_eq) * math.sin(omega * 600.0)) / vz
    assert pointing_error(model, final, 600.0) == pytest.approx(analytic, rel=1e-6)
    assert pointing_error(model, final, 600.0) == pytest.approx(8.5e-9, rel=0.01)


def test_envelope_is_the_phase_free_amplitude():
    model, final = _passive_seed([1e-5, 0, 1e-3, 0])
    estimator = EnvelopeEstimator(model)
    envelope = estimator.peak_speed(final, np.zeros(2)) / model.equilibrium_speed(600.0)
    omega, x_eq = math.sqrt(500.0 * 10), 1e-2
    expected = omega * abs(1e-5 - x_eq) / 6e7  # docs/physics.md §2: ≈ 1.2e-8
    assert envelope == pytest.approx(expected, rel=1 - math.cos(math.pi / 32))
    assert envelope == pytest.approx(1.18e-8, rel=0.01)
    assert pointing_error(model, final, 600.0) <= envelope * (1 + 1e-9)


def test_envelope_sums_two_modes_and_respects_the_held_input():
    model = PlanarModel(DEEP_DISH)
    estimator = EnvelopeEstimator(model)
    state = np.array([1e-2, 0.0, 1e-3, 0.0])
    # Reference: brute-force maximum of |Vx| over a long, finely sampled propagation.
    phi, _ = model.discretize(2e-4)
    s, peak = state.copy(), 0.0
    for _ in range(50_000):  # 10 s, many beat periods
        s = phi @ s
        peak = max(peak, abs(s[1]))
    assert estimator.peak_speed(state, np.zeros(2)) == pytest.approx(peak, rel=0.01)
    # A held beam offset moves the equilibrium: starting at that equilibrium, nothing moves.
    beam = np.array([3e-3, 0.0])
    equilibrium = np.linalg.solve(model.A, -model.B @ beam)
    assert estimator.peak_speed(equilibrium, beam) < 1e-12


def test_tolerance_constant_matches_eq20():
    from sail_env.physics.mission import pointing_tolerance_rad

    assert POINTING_TOLERANCE_RAD == pytest.approx(pointing_tolerance_rad(4e8), rel=0.01)


def test_an_unstable_sails_look_ahead_is_bounded_so_its_envelope_stays_finite():
    """A spinning flat sail grows at 100 /s while its slow beat (0.03 rad/s) sets a look-ahead of
    200 s: e^20,000 overflowed the table into a non-finite reward. The look-ahead stops at
    MAX_LOOKAHEAD_GROWTH e-folds."""
    import gymnasium as gym

    from sail_env.physics.linear import mode_rates
    from sail_env.physics.pointing import MAX_LOOKAHEAD_GROWTH

    plant = gym.make("LightSail3D-v0", sail_shape="flat", spin_rad_s=10.0).unwrapped.episode_spec.plant
    growth, _ = mode_rates(plant.nominal.A)
    assert growth > 50
    with np.errstate(over="raise", invalid="raise"):
        table = plant.params(np.ones((1, plant.n_factors))).envelope[0]
    assert np.all(np.isfinite(table)) and np.abs(table).max() < np.exp(2 * MAX_LOOKAHEAD_GROWTH)



def test_the_envelope_recurrence_is_the_exact_propagation_at_its_samples_and_held_after_them():
    """The table's compiled recurrence (``Φ ← Φ₁ Φ``, ``Γ ← Φ₁ Γ + Γ₁``, fixed-order sums) against
    ``[Φ(t), Γ(t)]`` computed directly at each sample time by a matrix exponential: two models of
    different lengths (the shorter repeats its last row), the rows of two velocities (3D-like)."""
    from sail_env.physics.linear import zoh_discretize
    from sail_env.physics.pointing import _fill_envelope

    models = [PlanarModel(SEED), PlanarModel(DEEP_DISH)]
    a, b = np.stack([m.A for m in models]), np.stack([m.B for m in models])
    h, samples, rows = np.array([1e-3, 2e-3]), np.array([40, 25]), np.array([1, 3])
    step_phi, step_gamma = zoh_discretize(a, b, h)
    table = np.full((2, 40, 2, 6), np.nan)
    _fill_envelope(step_phi, step_gamma, samples, rows, table)
    for j in range(2):
        for i in range(samples[j]):
            phi, gamma = zoh_discretize(a[j:j + 1], b[j:j + 1], np.array([i * h[j]]))
            expected = np.concatenate([phi[0], gamma[0]], axis=-1)[rows]
            np.testing.assert_allclose(table[j, i], expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
        assert np.all(table[j, samples[j]:] == table[j, samples[j] - 1])

