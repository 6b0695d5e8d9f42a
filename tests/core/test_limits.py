"""Issue 9's reproductions: every valid configuration runs to a clean end, every invalid input or
physically impossible configuration is refused up front with one ValueError naming the limit."""

import functools
import math

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401  (registers the ids)
from sail_env.core.spec import task_spec
from sail_env.physics.randomisation import MAX_PUSH_NOISE, Randomisation
from sail_env.envs import LightSailEnv
from sail_env.envs.vector import LightSailVectorEnv
from sail_env.physics import DEEP_DISH, FLAT, SEED, SailConfig
from sail_env.physics.checks import MAX_CONTROL_STEPS
from sail_env.physics.planar.plant import PlanarPlant
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.plant import RigidTaskConfig
from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.tasks import DEEP_DISH_START_HALF_WIDTHS, REALISTIC_DISTURBANCES

ZERO = np.zeros(2, dtype=np.float32)


def episode(env_id="LightSail-v0", seed=0, options=None, **kwargs):
    """Issue 9's ``ep``: make, reset(seed), zero commands to the end; checks every observation and reward."""
    env = gym.make(env_id, **kwargs)
    obs, info = env.reset(seed=seed, options=options)
    observations, done = [obs], False
    with np.errstate(over="raise", invalid="raise"):
        while not done:
            obs, reward, terminated, truncated, info = env.step(ZERO)
            observations.append(obs)
            assert math.isfinite(reward)
            done = terminated or truncated
    for obs in observations:
        assert env.observation_space.contains(obs) and np.all(np.isfinite(obs))
    assert info["diverged"] or math.isfinite(info["terminal_pointing_rad"])
    return len(observations) - 1, info


# ---------------------------------------------------------------- valid configurations that crashed
def test_unstable_sail_that_leaves_the_beam_before_control_ends_at_the_first_step():
    # 10 s of a 100/s divergence: the pre-control Gaussian was e^2000 wide (LinAlgError).
    steps, info = episode(config=FLAT.replace(control_start_s=10.0))
    assert steps == 1 and info["diverged"] is True and info["terminal_pointing_rad"] == math.inf


def test_strong_push_noise_on_the_deep_dish_runs_to_the_end():
    # The spread grows as e^{0.75 t} (parametric excitation), e^450 over the coast: now in pieces.
    steps, info = episode("LightSailDeepDish-v0", push_noise=0.2)
    assert steps == SEED.control_steps


@pytest.mark.parametrize("radius", [12.0, 20.0, 50.0])
def test_realistic_disturbances_on_shallow_dishes(radius):
    config = DEEP_DISH.replace(curvature_radius_m=radius, control_start_s=10.0)
    for seed in range(5):
        episode(seed=seed, config=config, start_half_widths=DEEP_DISH_START_HALF_WIDTHS, **REALISTIC_DISTURBANCES)


def test_window_ending_exactly_at_the_cutoff_is_scored_there():
    config = SEED.replace(control_window_s=0.35, beam_cutoff_s=0.35)
    steps, info = episode(config=config)
    assert steps == 70 and info["cutoff_s"] == 0.35 and not info["diverged"]
    # Nothing is left to coast: the scored state is the window's last, its pointing |Vx| / (F t / m).
    assert info["terminal_state"] == info["state"]
    speed = config.push_force_n / config.total_mass_kg * 0.35
    assert info["terminal_pointing_rad"] == pytest.approx(abs(info["state"]["vx"]) / speed, rel=1e-12)


@pytest.mark.parametrize("config, kwargs, earliest", [
    (SEED.replace(control_window_s=0.3526, beam_cutoff_s=0.3526), {}, "0.3526"),  # 71 whole steps end at 0.355 s
    (SEED.replace(control_start_s=10.0, beam_cutoff_s=11.0), {"light_delay": True}, "11"),  # commands in flight
    # The last command, sent at 10.995 s, arrives 4 steps (D = ½ a t² / c = 20.2 ms) later: after 11.0175 s.
    (SEED.replace(control_start_s=10.0, beam_cutoff_s=11.0175), {"light_delay": True}, "11.0175"),
])
def test_cutoff_before_the_last_command_arrives_is_refused(config, kwargs, earliest):
    with pytest.raises(ValueError, match=f"beam_cutoff_s - cutoff_jitter_s = {earliest} s must be >="):
        LightSailEnv(config, **kwargs)


def test_a_cutoff_jitter_reaching_into_the_window_names_its_range():
    """The earliest cut-off falls in the window: the message names cutoff_jitter_s and its range."""
    with pytest.raises(ValueError, match=r"^cutoff_jitter_s must be in \[0, 1\] s: .* got 1.5$"):
        LightSailEnv(SEED.replace(beam_cutoff_s=2.0), cutoff_jitter_s=1.5)


def test_parameter_spread_that_can_draw_an_invalid_sail_is_refused():
    with pytest.raises(ValueError, match="parameter_spread=0.05 can draw strut_length_m < com_distance_m"):
        LightSailEnv(SEED.replace(strut_length_m=10.0), parameter_spread=0.05)
    with pytest.raises(ValueError, match="curvature_radius_m < aperture_radius_m"):
        LightSailEnv(SEED.replace(curvature_radius_m=2.1), parameter_spread=0.1)
    # At the limit every draw is valid: 200 resets.
    env = LightSailEnv(SEED.replace(strut_length_m=10.0 * 1.05 / 0.95), parameter_spread=0.05)
    for seed in range(200):
        env.reset(seed=seed)


# ---------------------------------------------------------------- physically impossible: refused
def test_newtonian_speed_past_light_at_cutoff_is_refused():
    with pytest.raises(ValueError, match="speed of light"):
        SEED.replace(push_force_n=1e6)  # 1e9 m/s² for 600 s
    # The limit is a t < c: just below passes, just above is refused.
    limit_force = SPEED_OF_LIGHT / SEED.beam_cutoff_s * SEED.total_mass_kg
    SEED.replace(push_force_n=0.999 * limit_force)
    with pytest.raises(ValueError, match="speed of light"):
        SEED.replace(push_force_n=1.001 * limit_force)
    # The fastest parameter draw and the latest cut-off count too.
    config = SEED.replace(push_force_n=0.95 * limit_force)
    with pytest.raises(ValueError, match="fastest draw of parameter_spread"):
        LightSailEnv(config, parameter_spread=0.1)
    with pytest.raises(ValueError, match="latest of cutoff_jitter_s"):
        LightSailEnv(config, cutoff_jitter_s=60.0)


def test_light_round_trip_longer_than_the_window_is_refused():
    # The 334,899,693-dimensional observation: now refused by the speed of light first.
    with pytest.raises(ValueError, match="speed of light"):
        LightSailEnv(SEED.replace(push_force_n=1e6, control_start_s=500.0), light_delay=True)
    # From 60 s the round trip (~240 steps) outlasts a 200-step window; 50 s (~170) is accepted.
    with pytest.raises(ValueError, match="light_delay: the round trip"):
        LightSailEnv(SEED.replace(control_start_s=60.0), light_delay=True)
    spec = LightSailEnv(SEED.replace(control_start_s=50.0), light_delay=True).episode_spec
    assert spec.history_length <= spec.n_steps + 2
    # The limit is the round trip a t² / (c dt) at the window's end t = start + 1 s: 200 steps at
    # t = √(200 c dt / a) = 54.75 s, so control may start at 53.7 s but not at 53.85 s.
    end = math.sqrt(200 * SPEED_OF_LIGHT * 0.005 / SEED.axial_acceleration_m_s2)
    assert end - 1.0 == pytest.approx(53.75, abs=0.005)
    LightSailEnv(SEED.replace(control_start_s=53.7), light_delay=True)
    with pytest.raises(ValueError, match="light_delay: the round trip"):
        LightSailEnv(SEED.replace(control_start_s=53.85), light_delay=True)


def test_windows_beyond_the_step_limit_are_refused():
    SEED.replace(control_window_s=MAX_CONTROL_STEPS * 0.005)
    with pytest.raises(ValueError, match="control_window_s / control_step_s"):
        SEED.replace(control_window_s=1.0, control_step_s=1e-320)  # the ratio overflows to inf


@pytest.mark.parametrize("timing, match", [
    ({"control_start_s": -1.0}, "control_start_s must be >= 0"),
    ({"control_window_s": 0.001}, "control_window_s must be >= control_step_s"),
    ({"control_start_s": 599.5}, "control_start_s \\+ control_window_s must be <= beam_cutoff_s"),
    ({"control_window_s": 1.0, "control_step_s": 1e-320}, "control_window_s / control_step_s"),
    ({"control_window_s": (MAX_CONTROL_STEPS + 1) * 0.005}, "control_window_s / control_step_s")])
def test_both_sails_check_the_windows_timing_alike(timing, match):
    """The planar and the 3D configurations share one timing check (the 3D one had lacked the step limit)."""
    RigidTaskConfig(control_window_s=MAX_CONTROL_STEPS * 0.005)
    for make in (SEED.replace, functools.partial(RigidTaskConfig, RigidSailConfig())):
        with pytest.raises(ValueError, match=match):
            make(**timing)


@pytest.mark.parametrize("kwargs, match", [
    ({"push_noise": 1e20}, "push_noise must be <= 0.25"),
    ({"push_noise": MAX_PUSH_NOISE * 1.001}, "push_noise"),
    ({"beam_jitter_m": 1e200}, r"beam_jitter_m must be in \[0, 2\] m"),
    ({"cutoff_jitter_s": 1e300}, "cutoff_jitter_s"),
    ({"start_half_widths": (1e308, 0, 0, 0)}, r"start_half_widths: \|x\| must be <= 2"),
    ({"start_half_widths": (0, 0, 0.06, 0)}, r"\|theta\|"),
    ({"max_beam_offset_m": 0.0}, "^max_beam_offset_m must be finite and > 0"),
    ({"max_beam_tilt_rad": math.inf}, "^max_beam_tilt_rad must be finite and > 0"),
])
def test_extreme_sizes_are_refused_at_construction(kwargs, match):
    with pytest.raises(ValueError, match=match):
        LightSailEnv(**kwargs)


@pytest.mark.parametrize("spread", [0.0, 0.1])
def test_start_limits_keep_every_drawn_sail_in_the_beam(spread):
    """A long sail (a / Lc = 0.04 < the 0.05 rad small-angle limit): a start may tilt up to
    |θ| = a / (Lc (1 + s)), so that |Lc θ| ≤ a for the longest Lc the spread draws, and turn up to
    |ω| = that / dt (not leaving within one step); just beyond either is refused."""
    config = SEED.replace(com_distance_m=50.0, strut_length_m=100.0)
    env = gym.make("LightSail-v0", config=config, parameter_spread=spread)
    tilt = config.aperture_radius_m / (config.com_distance_m * (1 + spread))
    rate = tilt / config.control_step_s
    env.reset(seed=0, options={"initial_state": {"theta": 0.999 * tilt, "omega": 0.999 * rate}})
    for state, name in (({"theta": 1.001 * tilt}, "theta"), ({"omega": 1.001 * rate}, "omega")):
        with pytest.raises(ValueError, match=rf"initial_state: \|{name}\| must be <= {tilt if name == 'theta' else rate:.4g}"):
            env.reset(seed=0, options={"initial_state": state})


@pytest.mark.parametrize("state, name", [({"x": 1e308}, "x"), ({"vx": 1e308}, "vx"), ({"theta": 1e308}, "theta"),
                                         ({"omega": 1e308}, "omega"), ({"x": -2.5}, "x")])
def test_starts_outside_the_beam_are_refused_at_reset(state, name):
    env = gym.make("LightSail-v0", config=SEED.replace(control_start_s=10.0), push_noise=0.01)
    with pytest.raises(ValueError, match=rf"initial_state: \|{name}\|"):
        env.reset(options={"initial_state": state})
    envs = gym.make_vec("LightSail-v0", num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match=rf"initial_state: \|{name}\|"):
        envs.reset(options={"initial_state": state})


def test_largest_documented_sizes_run_cleanly():
    """Every disturbance at its documented maximum, starts at the edge of the limits: a clean episode."""
    kwargs = dict(push_noise=MAX_PUSH_NOISE, beam_jitter_m=DEEP_DISH.aperture_radius_m, parameter_spread=0.2,
                  sensor_noise_std=(1e6, 1e6, 1e6, 1e6), cutoff_jitter_s=590.0, light_delay=True)
    for config in (SEED, DEEP_DISH, FLAT.replace(control_start_s=5.0)):
        env = LightSailEnv(config, **kwargs)
        limits = env.episode_spec.start_limits
        for seed, start in enumerate((limits, -limits, np.zeros(4))):
            env.reset(seed=seed, options={"initial_state": dict(zip(("x", "vx", "theta", "omega"), start))})
            done = False
            while not done:
                obs, reward, done, _, info = env.step(np.ones(2, dtype=np.float32))
                assert env.observation_space.contains(obs) and math.isfinite(reward)


# ---------------------------------------------------------------- inputs that were misread
@pytest.mark.parametrize("kwargs, match", [
    ({"light_delay": "no"}, "light_delay must be True or False"),
    ({"light_delay": 1}, "light_delay must be True or False"),
    ({"max_beam_offset_m": True}, "max_beam_offset_m must be a real number"),
    ({"max_beam_tilt_rad": "2e-3"}, "max_beam_tilt_rad must be a real number"),
    ({"beam_jitter_m": "1e-5"}, "beam_jitter_m must be a real number"),
    ({"parameter_spread": np.array([0.1])}, "parameter_spread must be a real number"),
    ({"sensor_noise_std": 0.1}, "sensor_noise_std must be a sequence of real numbers"),
    ({"sensor_noise_std": "1234"}, "sensor_noise_std must be a sequence of real numbers"),
    ({"start_half_widths": (0, 0, False, 0)}, r"start_half_widths\[2\] must be a real number"),
    ({"config": None}, "config must be a SailConfig or one of"),
    ({"config": {"push_force_n": 1.0}}, r"config must be a SailConfig.*SailConfig\(\*\*fields\)"),
])
def test_misread_arguments_are_refused_in_the_users_terms(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make("LightSail-v0", **kwargs)
    with pytest.raises(ValueError, match=match):
        gym.make_vec("LightSail-v0", num_envs=2, vectorization_mode="vector_entry_point", **kwargs)


def test_numpy_scalars_are_real_numbers_and_give_the_same_episode():
    plain = episode(seed=3, config=SEED.replace(push_force_n=100.0), max_beam_offset_m=0.02,
                    options={"initial_state": {"x": 1e-3}})
    numpy = episode(seed=3, config=SEED.replace(push_force_n=np.float32(100.0)), max_beam_offset_m=np.float64(0.02),
                    sensor_noise_std=np.zeros(4), options={"initial_state": {"x": np.float64(1e-3)}})
    assert plain[1]["terminal_pointing_rad"] == numpy[1]["terminal_pointing_rad"]
    assert type(SailConfig(push_force_n=np.int64(100)).push_force_n) is float
    with pytest.raises(ValueError, match="com_distance_m must be a real number"):
        SEED.replace(com_distance_m=np.bool_(True))


@pytest.mark.parametrize("state, match", [({"x": "0.001"}, r"initial_state\['x'\] must be a real number"),
                                          ({"x": True}, r"initial_state\['x'\] must be a real number"),
                                          ([0.0, 0, 0, 0], "initial_state must be a dict")])
def test_misread_initial_states_are_refused(state, match):
    env = gym.make("LightSail-v0")
    with pytest.raises(ValueError, match=match):
        env.reset(options={"initial_state": state})


def test_vector_initial_state_array_must_be_real():
    envs = gym.make_vec("LightSail-v0", num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(ValueError, match=r"finite real array of shape \(2, 4\)"):
        envs.reset(options={"initial_state": np.full((2, 4), "0.001")})
    envs.reset(options={"initial_state": np.zeros((2, 4), dtype=np.float32)})


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_vector_env_refuses_non_finite_actions_and_a_step_before_reset(bad):
    envs = gym.make_vec("LightSail-v0", num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(RuntimeError, match=r"^step\(\) called before reset\(\)$"):
        envs.step(np.zeros((2, 2)))
    envs.reset(seed=0)
    with pytest.raises(ValueError, match="^actions must be finite$"):
        envs.step(np.array([[0.0, 0.0], [bad, 0.0]]))


def test_vector_env_builds_no_info_on_a_step_that_ends_nothing():
    envs = gym.make_vec("LightSail-v0", num_envs=2, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    _, _, terminated, truncated, info = envs.step(np.zeros((2, 2)))
    assert not terminated.any() and not truncated.any() and info == {}


def test_vector_env_final_observation_and_score_are_the_single_envs():
    envs = gym.make_vec("LightSail-v0", num_envs=2, vectorization_mode="vector_entry_point")
    envs.reset(seed=5)
    singles = [gym.make("LightSail-v0") for _ in range(2)]
    for i, env in enumerate(singles):
        env.reset(seed=5 + i)
    while True:
        obs, _, terminated, _, info = envs.step(np.zeros((2, 2)))
        last = [env.step(np.zeros(2)) for env in singles]
        if terminated.all():
            break
        np.testing.assert_allclose(obs, [step[0] for step in last], rtol=1e-6)
    keys = ("terminal_pointing_rad", "terminal_envelope_rad", "is_success", "diverged", "cutoff_s")
    for i, (final_obs, *_, single_info) in enumerate(last):
        np.testing.assert_allclose(info["final_obs"][i], final_obs, rtol=1e-6)
        for key in keys:
            np.testing.assert_allclose(info["final_info"][key][i], single_info[key], rtol=1e-6)
            assert info["final_info"][f"_{key}"][i]


def test_vector_env_from_a_spec_is_one_env_by_default_and_does_not_render():
    spec = gym.make("LightSail-v0").unwrapped.episode_spec
    envs = LightSailVectorEnv.from_spec(spec)
    assert envs.num_envs == 1 and envs.observation_space.shape == (1, spec.observation_size)
    with pytest.raises(ValueError, match="LightSailVectorEnv does not render; render_mode must be None"):
        LightSailVectorEnv.from_spec(spec, 2, "rgb_array")


@pytest.mark.parametrize("action", [np.zeros((1, 2)), np.array(["0", "0"]), np.array([True, False]), np.zeros(3),
                                    np.array([None, None])])
def test_misread_actions_are_refused_naming_the_shape(action):
    env = gym.make("LightSail-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must be 2 real numbers \(shape \(2,\)\)"):
        env.step(action)


@pytest.mark.parametrize("actions", [np.zeros(2), np.zeros((1, 2)), np.zeros((3, 2, 1)), np.full((3, 2), "0"),
                                     np.zeros((3, 2), dtype=bool)])
def test_misread_vector_actions_are_refused_naming_the_shape(actions):
    envs = gym.make_vec("LightSail-v0", num_envs=3, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions must be real numbers of shape \(3, 2\)"):
        envs.step(actions)


def test_randomisation_holds_the_sensor_noise_as_four_floats():
    """However given (a list, NumPy numbers), the sensor noise is kept as a tuple of four floats: the
    same task compares equal and hashes alike."""
    given = Randomisation(sensor_noise_std=[np.float32(1e-4), 0, 0, np.int64(1)])
    assert given.sensor_noise_std == (float(np.float32(1e-4)), 0.0, 0.0, 1.0)
    assert all(type(v) is float for v in given.sensor_noise_std)
    same = Randomisation(sensor_noise_std=given.sensor_noise_std)
    assert given == same and hash(given) == hash(same)


@pytest.mark.parametrize("name", ["beam_jitter_m", "push_noise", "cutoff_jitter_s", "parameter_spread",
                                  "ground_jitter_rad", "dust_density_m3", "dust_grain_mass_kg"])
def test_negative_disturbance_sizes_are_refused(name):
    with pytest.raises(ValueError, match=f"^{name} must be finite and >= 0, got -0.01"):
        task_spec(functools.partial(PlanarPlant, SEED), (0, 0, 0, 0), **{name: -0.01})


def test_parameter_spread_range_is_half_open():
    Randomisation(parameter_spread=0.4999)
    with pytest.raises(ValueError, match=r"parameter_spread must be in \[0, 0.5\), got 0.5"):
        Randomisation(parameter_spread=0.5)
