"""The 3D env's keywords at and beyond their limits (issue 20): each bad value is one ValueError naming
the keyword and its range, decided at construction; NumPy scalars are accepted like floats; the start
states are limited radially, as divergence is; ``reset``'s arguments are parsed the same way by the
single and the vector env."""

import dataclasses
import inspect
import math
import re
import time

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401  (registers the ids)
from sail_env.core.spec import task_spec
from sail_env.physics import randomisation
from sail_env.envs import params
from sail_env.envs.planar import LightSailEnv
from sail_env.envs.rigid3d import LightSail3DEnv
from sail_env.physics import disturbances


def _refused(kwargs: dict, field: str) -> str:
    """The one-line ValueError message of ``kwargs``, which must name ``field`` first."""
    start = time.perf_counter()
    with pytest.raises(ValueError) as error:
        LightSail3DEnv(**kwargs)
    message = str(error.value)
    assert time.perf_counter() - start < 10.0, "decided at construction, quickly"
    assert "\n" not in message and re.match(rf"^{field}\b", message), message
    return message


@pytest.mark.parametrize("kwargs, field, valid_range", [
    ({"beam_profile": "annulus", "beam_radius_m": 100.0}, "beam_radius_m", r"\[2.12e-06, 3.941\] m"),
    ({"beam_radius_m": 1e300}, "beam_radius_m", r"\[1.06e-06, 20\] m"),
    ({"beam_radius_m": 1e-300}, "beam_radius_m", r"\[1.06e-06, 20\] m"),
    ({"beam_profile": "gaussian", "beam_radius_m": 0.05}, "beam_radius_m", r"\[0.2, 28.21\] m"),
    ({"beam_profile": "multi-gaussian", "beam_radius_m": 100.0}, "beam_radius_m", r"\(0, 3.113\] m"),
    ({"curvature_radius_m": 1e300}, "curvature_radius_m", r"\(2, 20000\] m"),
    ({"sail_shape": "cone", "curvature_radius_m": 1e5}, "curvature_radius_m", r"\(2, 20000\] m"),
    ({"dust_density_m3": 1e18, "dust_grain_mass_kg": 1e-15}, "dust_density_m3", r"<= 0.005639 per m³"),
    ({"dust_density_m3": 1e-6, "dust_grain_mass_kg": 1e10}, "dust_density_m3", r"<= 5.639e-28 per m³"),
    ({"dust_density_m3": 1e-30, "dust_grain_mass_kg": 1e10}, "dust_grain_mass_kg", r"<= 4.23e-09 kg"),
    ({"dust_density_m3": 1.0, "dust_grain_mass_kg": 1e-30}, "dust_grain_mass_kg", r">= 1.674e-27 kg"),
    ({"diffraction_length_m": 1e-300}, "diffraction_length_m", r">= 4900 m"),
    ({"spin_rad_s": 1e25}, "spin_rad_s", r"\[-628.3, 628.3\] rad/s"),
    ({"spin_rad_s": -1e50}, "spin_rad_s", r"\[-628.3, 628.3\] rad/s"),
    ({"spin_rad_s": 1e300}, "spin_rad_s", r"\[-628.3, 628.3\] rad/s"),
    ({"ground_jitter_rad": 1e-3}, "ground_jitter_rad", r"\[0, 2.834e-11\] rad"),
    ({"beam_jitter_m": 3.0}, "beam_jitter_m", r"\[0, 2\] m"),
    ({"com_distance_m": 25.0}, "com_distance_m", r"\(0, 20\] m"),
    ({"cutoff_jitter_s": 1e300}, "cutoff_jitter_s", r"\[0, 599\] s"),
    ({"power_control": 0.7}, "power_control", r"\[0, 0.5\]"),
])
def test_every_keyword_beyond_its_range_is_one_value_error_with_the_range(kwargs, field, valid_range):
    """Each of issue 20's crashes (LinAlgError, OverflowError, ZeroDivisionError, NumPy's "lam value too
    large" at reset, LinAlgError mid-episode, an 8-minute gym.make, NaN observations) is refused."""
    assert re.search(valid_range, _refused(kwargs, field))


@pytest.mark.parametrize("kwargs", [
    {"spin_rad_s": 628.0}, {"spin_rad_s": -600.0}, {"beam_radius_m": 19.9}, {"curvature_radius_m": 2e4}, {"sail_shape": "cone", "curvature_radius_m": 2e4},
    {"beam_profile": "gaussian", "beam_radius_m": 0.2}, {"beam_profile": "annulus", "beam_radius_m": 3.9},
    {"diffraction_length_m": 5e3}, {"ground_jitter_rad": 2.8e-11}, {"com_distance_m": 20.0},
    {"dust_density_m3": 5e-3, "dust_grain_mass_kg": 1e-15, "cutoff_jitter_s": 599.0},
])
def test_values_at_the_limits_play_a_finite_episode(kwargs):
    env = LightSail3DEnv(**kwargs)
    done = False
    with np.errstate(divide="raise", invalid="raise", over="raise"):  # no observation divides by a zero scale
        obs, _ = env.reset(seed=0)
        while not done:
            obs, reward, done, _, info = env.step(np.full(env.action_space.shape, 0.3, dtype=np.float32))
            assert env.observation_space.contains(obs) and np.isfinite(obs).all() and math.isfinite(reward)
    assert info["diverged"] or math.isfinite(info["terminal_pointing_rad"])


def env_keywords() -> list[str]:
    """Every keyword of the 3D envs: the 3D ones, the episode keywords every env shares and the
    registered random disturbances' (the 3D sail carries them all)."""
    own = list(params.keywords(params.Rigid3DParams))
    shared = [name for name in inspect.signature(task_spec).parameters
              if name not in ("make_plant", "default_start_half_widths", "randomness")]
    episode = list(randomisation.FIELDS)
    return own + shared + episode + list(disturbances.keywords())


def test_every_keyword_is_in_the_docstrings_table_with_its_range():
    table = LightSail3DEnv.__doc__.split("## Arguments")[1].split("``info[")[0]
    for name in env_keywords():
        assert f"``{name}``" in table, name
    assert "π / dt" in table  # the range as a rule, not one setting's number


def _table_rows(env: type) -> dict[str, str]:
    """The ``## Arguments`` table of ``env``'s docstring: each keyword its row names, and the row's default."""
    table = env.__doc__.split("## Arguments")[1]
    rows = {}
    for line in table.splitlines():
        cells = [cell.strip() for cell in line.split("|")[1:-1]]
        if len(cells) >= 2 and cells[0].startswith("``"):
            for name in re.findall(r"``(\w+)``", cells[0]):
                rows[name] = cells[1]
    return rows


def _shown(value: object) -> str:
    """A default as the tables write it."""
    return f'``"{value}"``' if isinstance(value, str) else f"{value:g}" if isinstance(value, float) else str(value)


@pytest.mark.parametrize("env, family, everything", [(LightSail3DEnv, params.Rigid3DParams, env_keywords),
                                                      (LightSailEnv, params.PlanarParams, None)])
def test_the_tables_name_only_keywords_and_the_params_defaults(env, family, everything):
    """Each model family's keywords are declared once (:mod:`sail_env.envs.params`): its env's table
    names no keyword that does not exist and shows each of the family's own keywords with the
    params' default, so that neither can change without the other."""
    rows = _table_rows(env)
    if everything is not None:
        assert set(rows) == set(everything())
    for field in dataclasses.fields(family):
        if field.init:
            assert rows[field.name] == _shown(field.default), field.name


NUMERIC = {"curvature_radius_m": 12.0, "com_distance_m": 9.0, "absorptivity": 0.1, "beam_radius_m": 1.5,
           "spin_rad_s": 1.0, "ground_jitter_rad": 1e-15, "diffraction_length_m": 1e10, "payload_offset_m": 5e-3,
           "dust_density_m3": 1e-6, "dust_grain_mass_kg": 1e-15, "control_start_s": 1.0, "max_beam_offset_m": 0.01,
           "max_beam_tilt_rad": 1e-3, "beam_jitter_m": 1e-5, "push_noise": 0.01, "cutoff_jitter_s": 1.0,
           "parameter_spread": 0.1, "power_control": 0.2}


def test_the_numeric_table_covers_every_numeric_keyword():
    skip = {"sail_shape", "beam_profile", "relativistic", "velocity_terms", "light_delay", "start_half_widths",
            "sensor_noise_std", "model_uncertainty",  # model_uncertainty: its fields, tests/physics/test_uncertainty.py
            "expected_paths"}  # a count: tests/core/test_expected_success.py
    assert set(NUMERIC) == set(env_keywords()) - skip


@pytest.mark.parametrize("name", sorted(NUMERIC))
@pytest.mark.parametrize("kind", [np.float64, np.float32, "int"])
def test_numpy_scalars_are_accepted_by_every_numeric_keyword(name, kind):
    """The README: ints, floats and NumPy real scalars everywhere, the same env as with a float."""
    value = NUMERIC[name]
    if kind == "int":
        if value != int(value):
            pytest.skip("not an integer value")
        given = np.int64(int(value))
    else:
        given, value = kind(value), float(kind(value))
    extra = {"dust_grain_mass_kg": 1e-15} if name == "dust_density_m3" else {}
    extra = {"dust_density_m3": 1e-6} if name == "dust_grain_mass_kg" else extra
    env, reference = LightSail3DEnv(**{name: given}, **extra), LightSail3DEnv(**{name: value}, **extra)
    spec, expected = env.episode_spec, reference.episode_spec
    np.testing.assert_array_equal(spec.nominal.A, expected.nominal.A)
    np.testing.assert_array_equal(spec.action_scale, expected.action_scale)


@pytest.mark.parametrize("name", sorted(NUMERIC))
@pytest.mark.parametrize("bad", [True, "1.0", np.array([1.0, 2.0])])
def test_bools_strings_and_arrays_are_refused_by_every_numeric_keyword(name, bad):
    if name == "power_control" and bad is True:
        pytest.skip("power_control=True is the default power input")
    _refused({name: bad}, name)


@pytest.mark.parametrize("name, bad", [("sail_shape", np.array(["dish", "flat"])), ("sail_shape", np.array(["dish"])),
                                       ("beam_profile", np.array(["gaussian", "annulus"])), ("sail_shape", 3)])
def test_an_array_shape_or_beam_is_a_clear_value_error(name, bad):
    assert "must be one of" in _refused({name: bad}, name)


def test_messages_name_the_real_constraint_and_only_the_envs_settings():
    assert "CoM lies between the sail and the payload" in _refused({"com_distance_m": 25.0}, "com_distance_m")
    message = _refused({"cutoff_jitter_s": 1e300}, "cutoff_jitter_s")
    assert "push_force_n" not in message
    message = _refused({"cutoff_jitter_s": 590.0, "parameter_spread": 0.45, "control_start_s": 1.0,
                        "power_control": 0.5}, "parameter_spread")
    assert "push_force_n" not in message and "beam_cutoff_s" not in message


@pytest.mark.parametrize("value, inputs", [(False, 4), (0, 4), (0.0, 4), (np.float64(0.0), 4), (np.bool_(False), 4),
                                           (True, 5), (np.bool_(True), 5), (0.1, 5), (np.float32(0.5), 5)])
def test_power_control_zero_is_no_power_input_like_false(value, inputs):
    env = LightSail3DEnv(power_control=value)
    assert env.action_space.shape == (inputs,)
    if inputs == 5:
        assert env.episode_spec.plant.input_ranges["1"] == pytest.approx(0.1 if value is True or value is np.True_
                                                                         else float(value))


@pytest.mark.parametrize("state, label", [({"x": 1.5, "y": 1.5}, "√(x² + y²)"),
                                          ({"theta_x": 0.05, "theta_y": 0.05}, "√(theta_x² + theta_y²)")])
@pytest.mark.parametrize("vector", [False, True])
def test_start_states_are_limited_radially(state, label, vector):
    """2.12 m from the axis is outside the 2 m aperture; a tilt of 0.071 rad beyond the 0.05 rad limit
    (it diverged at step 1)."""
    env = (gym.make_vec("LightSail3D-v0", num_envs=2, vectorization_mode="vector_entry_point") if vector
           else gym.make("LightSail3D-v0"))
    with pytest.raises(ValueError, match=re.escape(f"initial_state: {label} must be <=")):
        env.reset(seed=0, options={"initial_state": state})
    inside = {key: 0.7 * value for key, value in state.items()}  # 0.99 of the limit
    env.reset(seed=0, options={"initial_state": inside})


def test_start_half_widths_are_limited_at_the_box_corner():
    widths = (1.5, 1.5, 0.1, 0.1, 2e-3, 2e-3, 1e-5, 1e-5)
    with pytest.raises(ValueError, match=re.escape("start_half_widths: √(x² + y²) must be <= 2")):
        LightSail3DEnv(start_half_widths=widths)
    LightSail3DEnv(start_half_widths=(1.4,) * 2 + widths[2:])


@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSail3D-v0"])
@pytest.mark.parametrize("vector", [False, True])
def test_reset_options_are_parsed_the_same_way_by_both_envs(env_id, vector):
    env = (gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point") if vector
           else gym.make(env_id))
    for options in ([("initial_state", {})], "initial_state", 3):
        with pytest.raises(ValueError, match=r"^options must be None or a dict with keys among \('initial_state', 'params'\)"):
            env.reset(seed=0, options=options)
    with pytest.raises(ValueError, match=r"^options keys must be among \('initial_state', 'params'\), got 'initial_states'$"):
        env.reset(seed=0, options={"initial_states": {"x": 1e-3}})
    with pytest.raises(ValueError, match=r"^initial_state keys must be among .*, got 1$"):
        env.reset(seed=0, options={"initial_state": {"x": 1e-3, 1: 0.0}})
    for seed in (1.5, True, "1", [1.0, 2.0]):
        with pytest.raises(ValueError, match=r"^seed must be None, an int >= 0 or a sequence of"):
            env.reset(seed=seed)
    env.reset(seed=np.int64(3), options={"initial_state": {"x": 1e-3}})
    env.reset(seed=None, options={})


def test_an_annulus_whose_hole_widens_past_the_sail_pushes_nothing_and_flies():
    """Found by the 3D property test: beyond the diffraction length the annulus's hole grows past the rim
    of a deep dish; the quadrature sent rays outside the sail (NaN push) and the flight's integration
    failed (RuntimeError at construction)."""
    from sail_env.physics.rigid3d.body import RigidSail
    from sail_env.physics.rigid3d.config import RigidSailConfig

    sail = RigidSail(RigidSailConfig(beam_profile="annulus", curvature_radius_m=3.02, com_distance_m=1.6))
    with np.errstate(invalid="raise"):
        assert [sail.centred_push(1.0, s) for s in (2.5, 5.0, 50.0)] == [0.0, 0.0, 0.0]
    env = LightSail3DEnv(beam_profile="annulus", curvature_radius_m=3.02, com_distance_m=1.6,
                         diffraction_length_m=math.exp(22.0))
    obs, _ = env.reset(seed=0)
    assert np.isfinite(obs).all()
