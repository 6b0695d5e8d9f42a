"""Rigid-body dynamics, axial flight and configuration of the 3D sail."""

import math

import numpy as np
import pytest
import scipy.integrate

from sail_env.physics.relativity import time_to_beta
from sail_env.physics.rigid3d import RigidSail, RigidSailConfig, state_from_small
from sail_env.physics.rigid3d.body import QUATERNION, RATES, axial_rates, rotation_matrices


def test_torque_free_symmetric_top_precesses_at_the_euler_rates():
    # Beam off. Body frame: ω⊥ turns at (I_a − I_t) Ω / I_t; lab frame: the axis cones about
    # the fixed angular momentum L at |L| / I_t (closed forms of the free symmetric top).
    sail = RigidSail(RigidSailConfig(aperture_radius_m=2.0, radial_nodes=2, angular_nodes=8))
    transverse, axial = sail.inertia[0, 0], sail.inertia[2, 2]
    spin, wobble = 400.0, 2.0
    start = state_from_small(omega_x=wobble, spin=spin)[0]
    duration = 0.05

    def rhs(_t, y):
        return sail.rates(y[None], np.zeros((1, 4)), power_factor=0.0)[0]

    times = np.linspace(0, duration, 7)
    solution = scipy.integrate.solve_ivp(rhs, (0, duration), start, t_eval=times, method="DOP853",
                                         rtol=1e-12, atol=1e-14)
    body_rate = (axial - transverse) * spin / transverse
    phase = body_rate * times
    expected = wobble * np.stack([np.cos(phase), np.sin(phase)])
    np.testing.assert_allclose(solution.y[10:12], expected, atol=1e-9 * wobble)
    np.testing.assert_allclose(solution.y[12], spin, rtol=1e-12)
    # Lab frame: L is conserved and the axis turns about it at |L| / I_t.
    states = solution.y.T
    rotation = rotation_matrices(states[:, QUATERNION])
    momentum = np.einsum("nij,jk,nk->ni", rotation, sail.inertia, states[:, RATES])
    np.testing.assert_allclose(momentum, momentum[:1].repeat(len(times), 0), atol=1e-10 * np.abs(momentum).max())
    axis = rotation[:, :, 2]
    l_hat = momentum[0] / np.linalg.norm(momentum[0])
    across = axis - (axis @ l_hat)[:, None] * l_hat
    angle = np.unwrap(np.arctan2(across @ np.cross(l_hat, across[0]), across @ across[0]))
    np.testing.assert_allclose(angle, np.linalg.norm(momentum[0]) / transverse * times, rtol=1e-8, atol=1e-8)


def test_relativistic_axial_flight_of_a_flat_mirror_follows_the_closed_form():
    # A flat perfect mirror catches the whole flat-top beam: Kulkarni, Lubin & Zhang's law.
    config = RigidSailConfig(shape="flat", beam_power_w=5e10, radial_nodes=2, angular_nodes=8)
    sail = RigidSail(config)

    def rhs(_t, y):
        return axial_rates(sail, y[0], y[1])

    beta = 0.2
    t_end = time_to_beta(beta, config.beam_power_w, config.total_mass_kg)
    solution = scipy.integrate.solve_ivp(rhs, (0, t_end), [0.0, 0.0], rtol=1e-11, atol=1e-14)
    momentum = solution.y[0, -1]
    assert momentum / math.sqrt(1 + momentum**2) == pytest.approx(beta, rel=1e-8)


def test_beyond_the_diffraction_length_the_push_falls_as_its_square():
    sail = RigidSail(RigidSailConfig(radial_nodes=4, angular_nodes=16))
    near = axial_rates(sail, 0.0, 1e9, diffraction_length_m=2e9, relativistic=False)[0]
    far = axial_rates(sail, 0.0, 6e9, diffraction_length_m=2e9, relativistic=False)[0]
    assert far == pytest.approx(near / 9, rel=1e-12)


@pytest.mark.parametrize("field, value", [
    ("shape", "sphere"), ("beam_profile", "top-hat"), ("aperture_radius_m", -1.0),
    ("curvature_radius_m", 1.5), ("reflectivity", 1.2), ("absorptivity", -0.1), ("sail_mass_kg", math.nan),
    ("beam_inner_radius_m", 3.0), ("beam_lobes", 0), ("radial_nodes", 1.5), ("strut_length_m", 5.0),
    ("strut_mass_kg", -1.0), ("beam_power_w", math.inf),
])
def test_invalid_configuration_names_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        RigidSailConfig().replace(**{field: value})


def test_reflectivity_and_absorptivity_cannot_exceed_one_together():
    with pytest.raises(ValueError, match="reflectivity \\+ absorptivity"):
        RigidSailConfig(absorptivity=0.1)


def test_table_command_prints_the_three_tables(capsys):
    from sail_env.analysis import tables3d as table

    table.main()
    out = capsys.readouterr().out
    assert out.count("### ") == 3 and "| flat | inf | flat-top | 0 |" in out
