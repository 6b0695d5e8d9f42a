"""Radiation force and torque of the rigid 3D sail against closed forms and independent quadratures."""

import math

import numpy as np
import pytest
import scipy.integrate

from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.rigid3d.body import RigidSail, rotation_matrices, quaternion_from_rotation_vector, state_from_small
from sail_env.physics.rigid3d.config import BEAM_PROFILES, RigidSailConfig
from sail_env.physics.rigid3d.forces import RadiationModel
from sail_env.physics.rigid3d.geometry import SailGeometry, inertia_tensor
from sail_env.physics.rigid3d.linearise import linearise

POWER = 1e10


def centred_wrench(config, offset=(0.0, 0.0), tilt_y=0.0, beam_tilt=(0.0, 0.0)):
    model = RadiationModel(config)
    rotation = rotation_matrices(quaternion_from_rotation_vector(np.array([[0.0, tilt_y, 0.0]])))
    return model.wrench(np.zeros((1, 3)), rotation, np.array([offset]), np.array([beam_tilt]), POWER)


@pytest.mark.parametrize("reflectivity, absorptivity", [(1.0, 0.0), (0.9, 0.1), (0.5, 0.2), (0.0, 1.0)])
def test_flat_sail_at_normal_incidence_is_pushed_by_2_rho_plus_alpha_times_p_over_c(reflectivity, absorptivity):
    config = RigidSailConfig(shape="flat", reflectivity=reflectivity, absorptivity=absorptivity)
    force, torque = centred_wrench(config)
    expected = (2 * reflectivity + absorptivity) * POWER / SPEED_OF_LIGHT
    np.testing.assert_allclose(force[0], [0, 0, expected], rtol=1e-14, atol=1e-12 * expected)
    np.testing.assert_allclose(torque[0], 0, atol=1e-12 * expected)


def test_a_beam_wider_than_the_sail_delivers_the_share_of_its_power_the_sail_intercepts():
    config = RigidSailConfig(shape="flat", beam_radius_m=3.0)
    force, _ = centred_wrench(config)
    assert force[0, 2] == pytest.approx(2 * POWER / SPEED_OF_LIGHT * (2.0 / 3.0) ** 2, rel=1e-14)
    # The same beam seen beyond the diffraction length, twice as wide: a quarter of the intensity.
    wide = RadiationModel(config).wrench(np.zeros((1, 3)), np.eye(3)[None], np.zeros((1, 2)), np.zeros((1, 2)),
                                         POWER, beam_scale=2.0)[0]
    assert wide[0, 2] == pytest.approx(force[0, 2] / 4, rel=1e-14)


def lens(delta, a):
    """Area of the overlap of two discs of radius a whose centres are delta apart."""
    return 2 * a**2 * math.acos(delta / (2 * a)) - 0.5 * delta * math.sqrt(4 * a**2 - delta**2)


@pytest.mark.parametrize("nodes", [(16, 128), (32, 512)])
def test_hard_edge_torque_and_its_derivative_match_the_lens_closed_form(nodes):
    # Flat mirror, flat-top beam of the aperture's size offset by delta: the lit lens is
    # symmetric about x = delta/2: the torque about y is −(2I/c) · area · delta/2 exactly.
    a, delta, h = 2.0, 0.6, 1e-5
    config = RigidSailConfig(shape="flat", radial_nodes=nodes[0], angular_nodes=nodes[1])
    intensity = POWER / (math.pi * a**2)

    def torque_y(d):
        return centred_wrench(config, offset=(d, 0.0))[1][0, 1]

    def exact(d):
        return -2 * intensity / SPEED_OF_LIGHT * lens(d, a) * d / 2

    stiffness = (torque_y(delta + h) - torque_y(delta - h)) / (2 * h)
    exact_stiffness = (exact(delta + h) - exact(delta - h)) / (2 * h)
    tolerance = 2e-4 if nodes[1] == 128 else 2e-5
    assert torque_y(delta) == pytest.approx(exact(delta), rel=tolerance)
    assert stiffness == pytest.approx(exact_stiffness, rel=tolerance)
    force_z = centred_wrench(config, offset=(delta, 0.0))[0][0, 2]
    assert force_z == pytest.approx(2 * intensity / SPEED_OF_LIGHT * lens(delta, a), rel=tolerance)


def masked_grid_stiffness(cells):
    """What a quadrature that merely masks grid points gives: a Cartesian grid over the aperture."""
    a, delta, h = 2.0, 0.6, 1e-5
    grid = (np.arange(cells) + 0.5) / cells * 2 * a - a
    u, v = np.meshgrid(grid, grid)
    inside = u**2 + v**2 <= a**2

    def torque(d):
        lit = inside & ((u - d) ** 2 + v**2 <= a**2)
        return np.sum(u * lit)

    return (torque(delta + h) - torque(delta - h)) / (2 * h)


def test_a_masked_grid_gets_the_hard_edge_stiffness_wrong():
    # Independent of the model: moving the beam by less than a cell changes no mask, so the
    # finite-difference stiffness of a masked grid is zero however fine the grid.
    assert masked_grid_stiffness(400) == 0.0


def test_geometry_of_a_spherical_cap_follows_archimedes():
    # Uniform areal density on a sphere: z is uniformly distributed over the cap's depth.
    geometry = SailGeometry("dish", 2.0, 4.0, 10.0)
    s = geometry.sagitta_m
    assert s == pytest.approx(4 - math.sqrt(12), rel=1e-14)
    _, z2 = geometry.mass_moments
    z_lo, z_hi = 10 - s, 10.0
    assert z2 == pytest.approx((z_hi**3 - z_lo**3) / (3 * s), rel=1e-12)
    # Seed-like point masses: the tensor is seed eq 10 plus the sail's own spread.
    point_limit = inertia_tensor(RigidSailConfig(aperture_radius_m=1e-3, curvature_radius_m=10.0))
    assert point_limit[0, 0] == pytest.approx(0.1, rel=1e-6)
    assert point_limit[2, 2] == pytest.approx(0.5e-3 * 0.5e-6, rel=1e-4)  # m a²/2
    rod = inertia_tensor(RigidSailConfig(strut_mass_kg=1e-3)) - inertia_tensor(RigidSailConfig())
    assert rod[0, 0] == pytest.approx(1e-3 * 20**2 / 12, rel=1e-12)  # rod centred on the CoM


@pytest.mark.parametrize("shape", ["dish", "balloon"])
@pytest.mark.parametrize("profile", BEAM_PROFILES)
def test_torque_of_a_specular_sphere_about_its_centre_of_curvature_vanishes(shape, profile):
    rng = np.random.default_rng(7)
    config = RigidSailConfig(shape=shape, curvature_radius_m=5.0, beam_profile=profile, angular_nodes=64)
    sail = RigidSail(config)
    n = 6
    states = state_from_small(x=rng.normal(0, 0.3, n), y=rng.normal(0, 0.3, n), theta_x=rng.normal(0, 0.05, n),
                              theta_y=rng.normal(0, 0.05, n), z=rng.normal(0, 0.1, n))
    inputs = np.concatenate([rng.normal(0, 0.3, (n, 2)), rng.normal(0, 0.02, (n, 2))], axis=-1)

    def torque_about_centre(sail):
        force, torque = sail.wrench(states, inputs)
        force_body = np.einsum("nji,nj->ni", rotation_matrices(states[:, 6:10]), force)
        centre = np.array([0.0, 0.0, sail.radiation.geometry.centre_z_m])
        return torque - np.cross(centre, force_body), np.abs(force).max() * 5.0

    residual, scale = torque_about_centre(sail)
    assert np.abs(residual).max() < 1e-13 * scale
    absorbing, scale = torque_about_centre(RigidSail(config.replace(reflectivity=0.9, absorptivity=0.1)))
    assert np.abs(absorbing).max() > 1e-4 * scale


@pytest.mark.parametrize("shape, single_sign", [("balloon", +1), ("dish", -1)])
def test_gaussian_pushes_a_balloon_out_and_a_ring_of_gaussians_holds_it(shape, single_sign):
    # Manchester & Loeb 2017: a centred Gaussian pushes a convex shell off the beam; four
    # Gaussians on a ring at the rim hold it. A concave dish is the mirror image.
    base = RigidSailConfig(shape=shape, curvature_radius_m=2.5)
    single = linearise(RigidSail(base.replace(beam_profile="gaussian")))
    ring = linearise(RigidSail(base.replace(beam_profile="multi-gaussian")))
    # d(Fx)/dx per unit mass: positive pushes outwards.
    assert np.sign(single.A[2, 0]) == single_sign and np.sign(single.A[3, 1]) == single_sign
    assert np.sign(ring.A[2, 0]) == -single_sign and np.sign(ring.A[3, 1]) == -single_sign


def reference_dish_wrench(radius, lc, a, theta_y, offset):
    """(Fx, Fz, τy) [per unit intensity × 2/c] on a perfectly reflecting dish tilted by theta_y about
    the CoM, in a normally incident flat-top beam of radius a offset by ``offset`` along x, by adaptive
    2-D quadrature over the plane across the beam with the lit domain's exact limits."""
    s, c = math.sin(theta_y), math.cos(theta_y)
    centre = np.array([(lc - radius) * s, 0.0, (lc - radius) * c])
    rim_z = lc - (radius - math.sqrt(radius**2 - a**2))
    rim = np.array([rim_z * s, 0.0, rim_z * c])

    def limits(v):
        if abs(v) >= a:
            return 0.0, 0.0
        half_beam = math.sqrt(a**2 - v**2)
        half_shadow = c * math.sqrt(a**2 - v**2)  # rim's shadow: ellipse with semi-axis a cos θ along x
        return max(offset - half_beam, rim[0] - half_shadow), min(offset + half_beam, rim[0] + half_shadow)

    def element(u, v, component):
        rel = np.array([u, v, 0.0]) - centre
        t = -rel[2] + math.sqrt(rel[2] ** 2 - (rel @ rel - radius**2))  # far root along z
        point = np.array([u, v, t])
        normal = (point - centre) / radius
        force = normal[2] * normal  # 2 I cos θ n du dv with 2I/c = 1
        return (force[0], force[2], point[2] * force[0] - point[0] * force[2])[component]

    return [scipy.integrate.dblquad(element, -a, a, lambda v: limits(v)[0], lambda v: max(limits(v)),
                                    args=(k,), epsabs=0, epsrel=1e-11)[0] for k in range(3)]


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_deep_dish_stiffnesses_match_an_independent_adaptive_quadrature():
    # The push falls as |offset| (light leaves over the edge), so forces have |·|·(·) terms and
    # central differences err by ~h: small steps on both sides.
    radius, lc, a, h = 4.0, 10.0, 2.0, 1e-6
    config = RigidSailConfig(curvature_radius_m=radius, com_distance_m=lc, radial_nodes=24, angular_nodes=256)
    model = linearise(RigidSail(config))
    unit = 2 * POWER / (math.pi * a**2) / SPEED_OF_LIGHT * config.beam_power_w / POWER
    d_offset = (np.subtract(reference_dish_wrench(radius, lc, a, 0, -h), reference_dish_wrench(radius, lc, a, 0, h))
                / (2 * h) * unit)  # beam offset +d is sail offset −d
    d_tilt = (np.subtract(reference_dish_wrench(radius, lc, a, h, 0), reference_dish_wrench(radius, lc, a, -h, 0))
              / (2 * h) * unit)
    inertia = model.inertia[1, 1]
    np.testing.assert_allclose(model.A[2, 0], d_offset[0] / model.mass_kg, rtol=1e-5)
    np.testing.assert_allclose(model.A[7, 0], d_offset[2] / inertia, rtol=1e-5)
    np.testing.assert_allclose(model.A[2, 5], d_tilt[0] / model.mass_kg, rtol=1e-5)
    np.testing.assert_allclose(model.A[7, 5], d_tilt[2] / inertia, rtol=1e-5)
    # Far from the equilibrium, where the beam's edge cuts the rim at corners: the values.
    reference = np.array(reference_dish_wrench(radius, lc, a, 0.02, 0.3)) * unit
    force, torque = RadiationModel(config).wrench(
        np.zeros((1, 3)), rotation_matrices(quaternion_from_rotation_vector(np.array([[0.0, 0.02, 0.0]]))),
        np.array([[0.3, 0.0]]), np.zeros((1, 2)), config.beam_power_w)
    torque_lab = rotation_matrices(quaternion_from_rotation_vector(np.array([0.0, 0.02, 0.0]))) @ torque[0]
    np.testing.assert_allclose([force[0, 0], force[0, 2], torque_lab[1]], reference, rtol=1e-9)
