"""The relativistic push in the 3D plant (docs/physics.md §14): the axial speed against the closed
form of :mod:`sail_env.physics.relativity`, and the piecewise coast against an integration of the
linear time-varying model."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate

from sail_env.physics.planar.config import DEEP_DISH
from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.rigid3d.plant import COAST_SEGMENT_S, RigidTaskConfig, RigidPlant
from sail_env.physics.relativity import time_to_beta
from sail_env.physics.rigid3d.config import RigidSailConfig


#: Error of the lateral velocity over the last 40 s, relative to its size (measured: 0.22 %).
BOUND = 4e-3


def realistic_plant(**kwargs) -> RigidPlant:
    sail = RigidSailConfig(curvature_radius_m=DEEP_DISH.curvature_radius_m, absorptivity=0.1, reflectivity=0.9)
    return RigidPlant(RigidTaskConfig(sail, spin_rad_s=1.0, relativistic=True, control_start_s=10.0), **kwargs)


def test_speed_follows_the_closed_form_of_the_doppler_law():
    plant = RigidPlant(RigidTaskConfig(RigidSailConfig(), relativistic=True))
    p = plant.params(np.ones((1, 3)))
    times = np.array([50.0, 300.0, 600.0])
    beta = plant.speed(p, times) / SPEED_OF_LIGHT
    # A perfect mirror's push F = 2P/c: the closed form's power is F c / 2.
    power = plant.linearisation.push_n * SPEED_OF_LIGHT / 2
    back = [time_to_beta(b, power, plant.linearisation.mass_kg) for b in beta]
    np.testing.assert_allclose(back, times, rtol=1e-7)
    assert beta[-1] > 0.1  # the law matters: Newton's a t would be 20 % faster at cut-off


def test_a_faster_draw_flies_the_nominal_flight_sooner():
    plant = realistic_plant(parameter_spread=0.1)
    factors = np.array([[0.95, 1.0, 1.05]])  # F/m 1.05/0.95 times the nominal
    p = plant.params(factors)
    nominal = plant.params(np.ones((1, 3)))
    ratio = 1.05 / 0.95
    np.testing.assert_allclose(plant.speed(p, np.array([300.0])), plant.speed(nominal, np.array([300.0 * ratio])),
                               rtol=1e-12)


def test_power_factor_scales_every_radiation_term_in_the_window():
    plant = realistic_plant()
    newtonian = RigidPlant(RigidTaskConfig(plant.config.sail, spin_rad_s=1.0, control_start_s=10.0))
    factor = plant.flight.power_factor(10.5)
    assert 0.99 < factor < 0.995
    np.testing.assert_allclose(plant.nominal.A - plant.kinematics, factor * (newtonian.nominal.A - plant.kinematics),
                               rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(plant.nominal.B, factor * newtonian.nominal.B, rtol=1e-12)


@pytest.mark.slow
def test_coast_matches_an_integration_of_the_time_varying_model():
    """The last 40 s before cut-off, where the power factor falls fastest (0.74 to 0.73 per 40 s
    at 600 s): the pieces' midpoint rule against DOP853. Over the whole 589 s coast the error
    of the lateral velocity is 0.6 % of its size (measured once: docs/physics.md §14)."""
    plant = realistic_plant()
    p = plant.params(np.ones((1, 3)))
    x0 = np.array([1e-3, -2e-3, 0.01, 0.02, 1e-4, -2e-4, 1e-3, 5e-4])
    u = np.array([2e-3, -1e-3, 1e-4, 5e-5])
    start, end = 560.0, 600.0
    window = plant.flight.power_factor(plant.config.window_middle_s)
    a_rad, b = p.a[0] - plant.kinematics, p.b[0]

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        scale = plant.flight.power_factor(t) / window
        return (plant.kinematics + scale * a_rad) @ x + scale * (b @ u)

    reference = scipy.integrate.solve_ivp(rhs, (start, end), x0, method="DOP853", rtol=1e-10, atol=1e-14).y[:, -1]
    x, diverged = plant.coast(p, x0[None], u[None], np.array([end - start]), None, np.array([start]))
    assert not diverged[0]
    assert (end - start) / COAST_SEGMENT_S >= 8
    velocity_error = np.hypot(*(x[0, 2:4] - reference[2:4])) / np.hypot(*reference[2:4])
    assert velocity_error < BOUND
    # Holding the window's model instead (no pieces) is far off: the test can fail.
    held, _ = RigidPlant.__mro__[1].coast(plant, p, x0[None], u[None], np.array([end - start]), None,
                                         np.array([plant.config.window_middle_s]))
    assert np.hypot(*(held[0, 2:4] - reference[2:4])) / np.hypot(*reference[2:4]) > 10 * BOUND


def test_shared_model_steps_as_a_draw_of_nominal_factors():
    """Without a spread the shared model's push expansion takes the window's radiation terms (the
    Doppler factor included), as every drawn model does: the same step to round-off."""
    plant = realistic_plant(push_noise=0.01)
    shared = plant.params(np.ones((1, 3)))
    drawn = plant._build(np.ones((1, 3)), shared=False)
    np.testing.assert_allclose(shared.step, drawn.step, rtol=1e-12, atol=1e-12 * np.abs(drawn.step).max())


@pytest.mark.parametrize("noisy", [False, True])
def test_coast_builds_its_pieces_in_batches_of_any_size(monkeypatch, noisy):
    """The pieces' propagators are built :data:`~sail_env.physics.linear_plant.COAST_BATCH` at a time: batches
    of 7 (cut mid-coast, different per environment) give the coast of one batch for all 118 pieces."""
    from sail_env.envs.rigid3d import rigid3d_spec
    from sail_env.physics import linear_plant as plant_module
    from sail_env.tasks import TASKS

    kwargs = dict(TASKS["LightSail3DRealistic-v0"])
    if not noisy:
        kwargs.update(ground_jitter_rad=0.0, push_noise=0.0, dust_density_m3=0.0)
    plant = rigid3d_spec(**kwargs).plant
    assert plant.time_varying and plant.noisy == noisy
    rng = np.random.default_rng(2)
    k = 3
    p = plant.params(np.stack([plant.draw(rng) for _ in range(k)]))
    x = rng.uniform(-1e-3, 1e-3, (k, 8)) * plant.start_limits()
    u = rng.uniform(-1, 1, (k, 4)) * 1e-6
    duration, start = np.array([589.0, 583.0, 594.0]), np.full(k, 11.0)
    normals = rng.standard_normal((k, 119, 8))
    monkeypatch.setattr(plant_module, "COAST_BATCH", 119 * k)
    one_batch, diverged = plant.coast(p, x, u, duration, normals, start)
    monkeypatch.setattr(plant_module, "COAST_BATCH", 7 * k)
    batches, diverged_too = plant.coast(p, x, u, duration, normals, start)
    np.testing.assert_allclose(batches, one_batch, rtol=1e-12, atol=0)
    assert not diverged.any() and not diverged_too.any()
    assert plant.coast_pieces(p, duration).tolist() == [118, 117, 119]
