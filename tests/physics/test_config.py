import math

import pytest

from sail_env.physics import DEEP_DISH, FLAT, PRESETS, SEED, push_force_from_laser
from sail_env.physics.constants import SPEED_OF_LIGHT


def test_seed_preset_is_the_papers_cgs_values_in_si():
    # Seed appendix: a = 200 cm, R = Lc = 1000 cm, L = 2000 cm, m1 = m2 = 0.5 g, F = 1e7 dyn, 600 s.
    assert (SEED.aperture_radius_m, SEED.curvature_radius_m, SEED.com_distance_m) == (2.0, 10.0, 10.0)
    assert SEED.strut_length_m == 20.0
    assert SEED.sail_mass_kg == SEED.craft_mass_kg == 0.5e-3
    assert SEED.push_force_n == pytest.approx(1e7 * 1e-5)
    assert SEED.beam_cutoff_s == 600.0
    # Seed eq 10 in its CGS code: I = m1 Lc^2 + m2 (L - Lc)^2 = 1e6 g cm^2 = 0.1 kg m^2.
    assert SEED.moment_of_inertia_kg_m2 == pytest.approx((0.5 * 1000**2 + 0.5 * 1000**2) * 1e-7)
    assert SEED.control_steps == 200
    assert set(PRESETS) == {"seed", "deep_dish", "flat"}
    assert DEEP_DISH.curvature_radius_m < DEEP_DISH.com_distance_m
    assert math.isinf(FLAT.curvature_radius_m) and FLAT.curvature_per_m == 0.0


@pytest.mark.parametrize("field, value", [
    ("sail_mass_kg", -1e-3), ("craft_mass_kg", 0.0), ("control_step_s", 0.0),
    ("aperture_radius_m", -2.0), ("push_force_n", math.nan), ("beam_cutoff_s", math.inf),
    ("curvature_radius_m", 1.0), ("strut_length_m", 5.0), ("control_window_s", 1e-4),
    ("control_start_s", -1.0), ("control_start_s", 599.5), ("com_distance_m", "10"),
])
def test_invalid_configuration_names_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        SEED.replace(**{field: value})


def test_laser_force():
    assert push_force_from_laser(50e9, 1.0) == pytest.approx(2 * 50e9 / SPEED_OF_LIGHT)
    assert push_force_from_laser(50e9, 0.0) == pytest.approx(50e9 / SPEED_OF_LIGHT)
    with pytest.raises(ValueError, match="reflectance"):
        push_force_from_laser(50e9, 1.5)
    with pytest.raises(ValueError, match="power_w"):
        push_force_from_laser(-1.0)
