"""The 3D plant's payload offset and dust impacts (docs/physics.md §15): the equilibrium against
the sphere's geometry, the torque against ``F e_c``, the constant term in the window and the coast
against scipy's exponential, the window's per-step impacts against the compound Poisson law and
the coast's second moments against a Monte Carlo of the impacts themselves."""

import numpy as np
import pytest
import scipy.linalg

from sail_env.core import EpisodeCore
from sail_env.envs.rigid3d import rigid3d_spec
from sail_env.physics.disturbances import split_keywords
from sail_env.physics.noise import mean_and_covariance, second_moment
from sail_env.physics.rigid3d.plant import OMEGA_Y, THETA_Y, RigidTaskConfig, RigidPlant
from sail_env.physics.rigid3d import RigidSailConfig

DEEP_MIRROR = RigidSailConfig(curvature_radius_m=4.0)


def _plant(sail: RigidSailConfig = DEEP_MIRROR, **kwargs) -> RigidPlant:
    sources, flight = split_keywords(kwargs)
    return RigidPlant(RigidTaskConfig(sail, **flight), disturbances=sources)


def _com_offset(plant: RigidPlant) -> float:
    sail = plant.config.sail
    return plant.config.payload_offset_m * sail.craft_mass_kg / sail.total_mass_kg


@pytest.mark.parametrize("spin", [0.0, 1.0])
def test_payload_tilts_the_mirror_until_the_force_line_passes_through_the_com(spin):
    """A specular sphere's force passes through its centre of curvature C, ``Lc − R`` ahead of the
    CoM on the axis: at rest the axis must lean by ``e_c / (Lc − R)`` to bring C over a CoM ``e_c``
    off the axis, whatever the beam (the steady state of ``A s + c = 0``)."""
    plant = _plant(payload_offset_m=4e-3, spin_rad_s=spin)
    rest = np.linalg.solve(plant.nominal.A, -plant.constant_term)
    sail = plant.config.sail
    expected = _com_offset(plant) / (sail.com_distance_m - sail.curvature_radius_m)
    assert rest[THETA_Y] == pytest.approx(expected, rel=1e-5)
    assert np.abs(rest[[2, 3, 6, 7]]).max() < 1e-12 * expected  # at rest


def test_payload_torque_is_the_push_times_the_com_offset():
    """At the seed point (``R = Lc``) a mirror's radiation exerts no torque about the CoM, so the
    offset's ``F e_c`` alone turns the sail: ``ω_y = F e_c t / I_t`` over 200 exact steps."""
    plant = _plant(RigidSailConfig(), payload_offset_m=2e-3)
    p = plant.params(np.ones((1, 3)))
    x, u = np.zeros((1, 8)), np.zeros((1, 4))
    for _ in range(200):
        x = plant.step(p, x, u)
    push = plant.acceleration_m_s2 * plant.config.sail.total_mass_kg
    expected = push * _com_offset(plant) * 200 * plant.dt / plant.linearisation.inertia[0, 0]
    assert x[0, OMEGA_Y] == pytest.approx(expected, rel=1e-6)


def test_constant_term_is_exact_in_the_steps_and_the_coast():
    """200 window steps, the noise-free coast and the mean of the dusty coast over the same second
    all equal scipy's exponential of ``[[A, B, c], 0]`` with the input held."""
    sail = RigidSailConfig(curvature_radius_m=4.0, absorptivity=0.1, reflectivity=0.9)
    plant = _plant(sail, payload_offset_m=5e-3, spin_rad_s=1.0, control_start_s=10.0)
    dusty = _plant(sail, payload_offset_m=5e-3, spin_rad_s=1.0, control_start_s=10.0,
                   dust_density_m3=1e-6, dust_grain_mass_kg=1e-15)
    rng = np.random.default_rng(0)
    x0 = rng.normal(size=(1, 8)) * np.array([1e-3, 1e-3, 1e-2, 1e-2, 1e-4, 1e-4, 1e-3, 1e-3])
    u = rng.normal(size=(1, 4)) * np.array([1e-3, 1e-3, 1e-4, 1e-4])
    aug = np.zeros((13, 13))
    lin = plant.linearisation
    aug[:8, :8], aug[:8, 8:12], aug[:8, 12] = lin.A, lin.B, plant.constant_term
    expected = scipy.linalg.expm(aug) @ np.concatenate([x0[0], u[0], [1.0]])
    p = plant.params(np.ones((1, 3)))
    x = x0
    for _ in range(200):
        x = plant.step(p, x, u)
    scale = np.abs(expected[:8]) + 1e-6 * np.abs(expected[:8]).max()
    np.testing.assert_allclose(x[0] / scale, expected[:8] / scale, atol=1e-8)
    coasted, diverged = plant.coast(p, x0, u, np.ones(1), None, np.full(1, 10.0))
    np.testing.assert_allclose(coasted[0] / scale, expected[:8] / scale, atol=1e-8)
    q = dusty.params(np.ones((1, 3)))
    pieces = dusty.coast_pieces(q, np.ones(1))
    mean, _ = dusty.coast(q, x0, u, np.ones(1), np.zeros((1, int(pieces[0]), 8)), np.full(1, 10.0))
    np.testing.assert_allclose(mean[0] / scale, expected[:8] / scale, atol=1e-8)
    assert not diverged[0]


def test_window_impacts_are_a_compound_poisson_process():
    """Each step's kick (the state after a step minus the noise-free step) has mean 0, variance
    ``λ dt σ²``, no kick at all with probability ``e^{−λ dt}`` and the excess kurtosis ``3/(λ dt)``
    of a Poisson count of Gaussian kicks (0 for a Gaussian)."""
    spec = rigid3d_spec(dust_density_m3=1e-4, dust_grain_mass_kg=1e-15)
    plant = spec.plant
    middle = np.full(1, 0.5 * spec.n_steps * spec.dt)
    unit_rate = plant.impact_rate_and_std(plant.params(np.ones((1, 3))), middle)[0] / 1e-4
    spec = rigid3d_spec(dust_density_m3=0.5 / (unit_rate[0] * spec.dt), dust_grain_mass_kg=1e-15)
    plant, n = spec.plant, 3000
    p = plant.params(np.ones((1, 3)))
    rate, std = plant.impact_rate_and_std(p, middle)
    assert rate[0] * spec.dt == pytest.approx(0.5)
    core = EpisodeCore(spec, n)
    core.reset(np.arange(n), [np.random.default_rng(seed) for seed in range(n)], np.zeros((n, 8)))
    x0 = core.state.x.copy()
    core.step(np.zeros((n, 4)))
    kicks = (core.state.x - plant.step(p, x0, np.zeros((n, 4))))[:, list(plant.impulse_rows)] / std
    mean, variance = kicks.mean(axis=0), kicks.var(axis=0)
    assert np.all(np.abs(mean) < 4 * np.sqrt(0.5 / n))
    np.testing.assert_allclose(variance, 0.5, rtol=0.15)
    assert np.mean(kicks[:, 0] == 0) == pytest.approx(np.exp(-0.5), abs=0.03)
    excess = (kicks**4).mean(axis=0) / variance**2 - 3
    assert np.all(excess > 3.0)  # 6 for λ dt = 0.5; a Gaussian's sampling spread is ~0.1 here


def test_coast_second_moments_match_a_monte_carlo_of_the_impacts():
    """Half a second of coast from 100 s into the flight (the stable, spinning, absorbing dish): the
    plant's white-noise moments against explicit impacts at Poisson times with the rate and size of
    their own moment (``Φ(T − τ)`` applied to each kick by eigen-decomposition)."""
    sail = RigidSailConfig(curvature_radius_m=4.0, absorptivity=0.1, reflectivity=0.9)
    plant = _plant(sail, spin_rad_s=1.0, dust_density_m3=2e-7, dust_grain_mass_kg=1e-13)
    p = plant.params(np.ones((1, 3)))
    start, duration = 100.0, 0.5
    u = np.zeros((1, 4))
    pieces = int(plant.coast_pieces(p, np.array([duration]))[0])
    piece = duration / pieces
    second = second_moment(np.zeros((1, 8)), np.zeros((1, 8, 8)))
    for i in range(pieces):
        middle = np.array([start + (i + 0.5) * piece])
        second = np.einsum("kij,kj->ki", plant._piece_propagators(p, u, middle[:, None], np.array([piece]))[0], second)
    _, covariance = mean_and_covariance(second)

    rng = np.random.default_rng(1)
    rows, end = list(plant.impulse_rows), start + duration
    peak_rate, _ = plant.impact_rate_and_std(p, np.array([end]))
    values, vectors = np.linalg.eig(plant.nominal.A)
    inverse = np.linalg.inv(vectors)
    samples = 4000
    ends = np.zeros((samples, 8))
    for k in range(samples):
        # Thinning: candidates at the (final, largest) rate, each kept with the rate at its time over it.
        candidates = rng.uniform(start, end, rng.poisson(peak_rate[0] * duration))
        rate, _ = plant.impact_rate_and_std(p, candidates)
        times = candidates[rng.uniform(size=len(candidates)) * peak_rate[0] < rate]
        _, std = plant.impact_rate_and_std(p, times)
        kicks = np.zeros((len(times), 8))
        kicks[:, rows] = std * rng.standard_normal((len(times), 4))
        modal = kicks @ inverse.T * np.exp(np.outer(end - times, values))
        ends[k] = (vectors @ modal.sum(axis=0)).real
    sampled = np.cov(ends[:, rows].T)
    np.testing.assert_allclose(np.diag(sampled), np.diag(covariance[0][np.ix_(rows, rows)]), rtol=0.1)
    assert np.abs(ends.mean(axis=0)[rows]).max() < 0.1 * np.sqrt(np.diag(sampled)).max()
    assert 5 < peak_rate[0] * duration < 50  # a Poisson number of impacts per sample
