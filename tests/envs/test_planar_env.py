import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
import scipy.linalg
from gymnasium.utils.env_checker import check_env
from hypothesis import given, settings
from hypothesis import strategies as st
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import sail_env  # noqa: F401  (registers the ids)
from sail_env.envs import LightSailEnv
from sail_env.physics import DEEP_DISH, SEED, PlanarModel, pointing_error
from sail_env.tasks import PLANAR_TASKS as TASKS

ZERO = np.zeros(2, dtype=np.float32)


def _run(env, policy=lambda obs: ZERO, **reset_kwargs):
    obs, info = env.reset(**reset_kwargs)
    observations, rewards, infos = [obs], [], [info]
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        observations.append(obs)
        rewards.append(reward)
        infos.append(info)
        done = terminated or truncated
    return np.array(observations), np.array(rewards), infos


@pytest.mark.parametrize("env_id", sorted(TASKS))
def test_checkers_pass_without_warnings(env_id):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(f"sail_env:{env_id}").unwrapped, skip_render_check=False)
        sb3_check_env(gym.make(env_id).unwrapped, warn=True)


@pytest.mark.parametrize("env_id", sorted(TASKS))
def test_same_seed_same_numbers(env_id):
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (400, 2)).astype(np.float32)
    runs = []
    for _ in range(2):
        env = gym.make(env_id)
        step = iter(actions)
        obs, rewards, infos = _run(env, lambda o: next(step), seed=42)
        runs.append((obs, rewards, infos[-1]["terminal_pointing_rad"], infos[-1]["cutoff_s"]))
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])
    assert runs[0][2:] == runs[1][2:]
    other = _run(gym.make(env_id), seed=43)[0]
    assert not np.array_equal(other[0], runs[0][0][0])


def test_passive_seed_sail_reproduces_the_physics():
    env = gym.make("LightSail-v0")
    start = {"x": 1e-5, "theta": 1e-3}
    obs, rewards, infos = _run(env, seed=0, options={"initial_state": start})
    assert infos[0]["state"] == {"x": 1e-5, "vx": 0.0, "theta": 1e-3, "omega": 0.0}
    # Independent: one exact propagation over the whole beam time.
    model = PlanarModel(SEED)
    phi, _ = model.discretize(600.0)
    expected = pointing_error(model, phi @ np.array([1e-5, 0, 1e-3, 0]), 600.0)
    final = infos[-1]
    assert final["terminal_pointing_rad"] == pytest.approx(expected, rel=1e-6)
    assert final["terminal_pointing_rad"] == pytest.approx(8.5e-9, rel=0.01)
    assert final["terminal_pointing_rad"] <= final["terminal_envelope_rad"] == pytest.approx(1.18e-8, rel=0.01)
    assert final["is_success"] is True and final["diverged"] is False
    # Seed Fig 5: X swings between 1e-5 m and ≈ 2 cm during the window.
    xs = [info["state"]["x"] for info in infos]
    assert min(xs) == pytest.approx(1e-5, rel=0.01) and max(xs) == pytest.approx(0.02, rel=0.01)
    assert obs[0][0] == pytest.approx(1e-5 / 1e-2) and obs[0][2] == pytest.approx(1.0)
    assert len(rewards) == SEED.control_steps


def test_initial_state_option_and_info():
    env = gym.make("LightSailDeepDish-v0")
    obs, info = env.reset(seed=1, options={"initial_state": {"vx": 0.2}})
    assert info["state"] == {"x": 0.0, "vx": 0.2, "theta": 0.0, "omega": 0.0}
    assert info["t"] == 0.0
    with pytest.raises(ValueError, match="initial_state"):
        env.reset(options={"initial_state": {"z": 1.0}})
    with pytest.raises(ValueError, match="initial_state"):
        env.reset(options={"initial_state": {"x": math.nan}})


@pytest.mark.parametrize("bad", [np.array([np.nan, 0.0]), np.array([0.0, np.inf]), np.zeros(3)])
def test_bad_actions_raise(bad):
    env = gym.make("LightSail-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(bad)


def test_bad_arguments_raise():
    with pytest.raises(ValueError, match="config"):
        LightSailEnv(config="round")
    with pytest.raises(ValueError, match="max_beam_offset_m"):
        LightSailEnv(max_beam_offset_m=0.0)
    with pytest.raises(ValueError, match="sensor_noise_std"):
        LightSailEnv(sensor_noise_std=(1.0, -1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="parameter_spread"):
        LightSailEnv(parameter_spread=0.7)
    with pytest.raises(ValueError, match="render_mode"):
        LightSailEnv(render_mode="ascii")


def test_out_of_range_actions_are_clipped():
    a = gym.make("LightSail-v0")
    b = gym.make("LightSail-v0")
    a.reset(seed=5)
    b.reset(seed=5)
    assert a.step(np.array([5.0, -7.0]))[0].tolist() == b.step(np.array([1.0, -1.0]))[0].tolist()


def test_flat_sail_diverges_cleanly():
    env = gym.make("LightSail-v0", config="flat")
    with np.errstate(over="raise", invalid="raise"):
        obs, rewards, infos = _run(env, seed=0)
    final = infos[-1]
    assert final["diverged"] is True and final["is_success"] is False
    assert math.isinf(final["terminal_pointing_rad"])
    assert np.all(np.isfinite(obs)) and np.all(np.isfinite(rewards))
    assert rewards[-1] == pytest.approx(-10.0)
    assert len(rewards) < SEED.control_steps  # a 100/s divergence leaves the beam within the window
    with pytest.raises(RuntimeError, match="reset"):
        env.step(ZERO)


def test_unstable_sail_held_steady_in_the_window_diverges_in_the_coast():
    # Starting exactly on the beam nothing moves in the window; the coast must still finish.
    env = gym.make("LightSail-v0", config="flat")
    _, _, infos = _run(env, seed=0, options={"initial_state": {}})
    assert infos[-1]["diverged"] is False and infos[-1]["terminal_pointing_rad"] == 0.0
    _, _, infos = _run(env, seed=0, options={"initial_state": {"x": 1e-12}})
    assert infos[-1]["diverged"] is True


def test_light_delay_lags_observation_and_command():
    env = gym.make("LightSailRealistic-v0", sensor_noise_std=(0, 0, 0, 0), beam_jitter_m=0.0,
                   push_noise=0.0, parameter_spread=0.0)
    spec = env.unwrapped.episode_spec
    obs, info = env.reset(seed=3)
    lag = int(spec.delay_steps(0))
    assert lag == round(0.5 * 1e5 * 10.0**2 / 299_792_458.0 / 0.005) == 3
    states = [info["state"]]
    observations = [obs]
    for _ in range(20):
        obs, _, _, _, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        states.append(info["state"])
        observations.append(obs)
    # The observation at step k shows the true state of step k − lag.
    for k in range(lag, 21):
        shown = spec.observation_to_state(observations[k])
        np.testing.assert_allclose(shown, list(states[k - lag].values()), rtol=1e-5)
    # The command history (newest first, distinct commands) and its length: tests/envs/test_disturbances.py.


@pytest.mark.parametrize("start", [0.5, 10.0])
def test_launch_state_is_flown_exactly_to_control_start(start):
    """Control starting ``start`` s into the flight: the state at control start is the exact
    propagation exp(A start) of the launch state (zero beam input before control)."""
    config = DEEP_DISH.replace(control_start_s=start)
    launch = {"x": 1e-3, "vx": 0.0, "theta": 1e-4, "omega": 0.0}
    _, info = gym.make("LightSail-v0", config=config).reset(seed=0, options={"initial_state": launch})
    expected = scipy.linalg.expm(PlanarModel(config).A * start) @ np.array(list(launch.values()))
    np.testing.assert_allclose(list(info["state"].values()), expected, rtol=1e-9, atol=1e-15)


def _check_delayed_observations(env, seed, steps=20):
    """The observation at step k shows the true state at step k − D(k), D(k) = round(½ a t² / c / dt)
    with the episode's own acceleration, also before control (k < D(k)): with zero commands, the
    exact propagation exp(A (k − D(k)) dt) of the state at control start. Returns D."""
    spec = env.unwrapped.episode_spec
    obs, info = env.reset(seed=seed)
    params = env.unwrapped.state.params
    a, accel = params.a[0], params.acceleration[0]
    t = spec.config.control_start_s + np.arange(steps + 1) * spec.dt
    delays = np.rint(0.5 * accel * t**2 / 299_792_458.0 / spec.dt).astype(int)
    start = np.array(list(info["state"].values()))
    observations = [obs] + [env.step(np.zeros(2, dtype=np.float32))[0] for _ in range(steps)]
    for k, observed in enumerate(observations):
        expected = scipy.linalg.expm(a * (k - delays[k]) * spec.dt) @ start
        np.testing.assert_allclose(spec.observation_to_state(observed), expected, rtol=1e-5, atol=1e-12)
    return delays


def test_light_delayed_observation_shows_the_drawn_sails_own_past():
    env = gym.make("LightSailRealistic-v0", sensor_noise_std=(0, 0, 0, 0), beam_jitter_m=0.0, push_noise=0.0)
    delays = _check_delayed_observations(env, seed=3)
    assert delays[0] == 4 != env.unwrapped.episode_spec.delay_steps(0)  # this draw's delay is not the nominal one


@pytest.mark.parametrize("disturbance", [{"beam_jitter_m": 1e-5}, {"push_noise": 0.01}, {"cutoff_jitter_s": 3.0},
                                         {"parameter_spread": 0.1}, {"sensor_noise_std": (1e-4, 1e-2, 1e-5, 1e-3)}])
def test_each_disturbance_alone_changes_the_episode_but_stays_finite(disturbance):
    """Each disturbance acts on its own (their sizes and where they act: tests/envs/test_disturbances.py)."""
    quiet = _run(gym.make("LightSailDeepDish-v0"), seed=7)
    noisy = _run(gym.make("LightSailDeepDish-v0", **disturbance), seed=7)
    a, b = quiet[2][-1], noisy[2][-1]
    assert not np.array_equal(quiet[0], noisy[0]) or a["terminal_pointing_rad"] != b["terminal_pointing_rad"]
    assert np.all(np.isfinite(noisy[0])) and np.isfinite(b["terminal_pointing_rad"])
    assert abs(b["cutoff_s"] - 600.0) <= disturbance.get("cutoff_jitter_s", 0.0)


def test_render_rgb_array():
    env = gym.make("LightSail-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(ZERO)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 0
    env.close()


@settings(max_examples=25, deadline=None)
@given(r=st.one_of(st.just(math.inf), st.floats(2.0, 40.0)), lc=st.floats(1.0, 20.0),
       mass=st.floats(1e-4, 1e-2), seed=st.integers(0, 2**16))
def test_random_configurations_never_produce_nan(r, lc, mass, seed):
    config = SEED.replace(curvature_radius_m=r, com_distance_m=lc, sail_mass_kg=mass, control_window_s=0.1)
    env = LightSailEnv(config, beam_jitter_m=1e-5, push_noise=0.01)
    rng = np.random.default_rng(seed)
    with np.errstate(over="raise", invalid="raise"):
        obs, rewards, infos = _run(env, lambda o: rng.uniform(-1, 1, 2).astype(np.float32), seed=seed)
    assert np.all(np.isfinite(obs)) and np.all(np.isfinite(rewards))
    final = infos[-1]
    assert final["diverged"] or np.isfinite(final["terminal_pointing_rad"])


def test_long_light_delay_with_noise_runs_to_the_cutoff():
    # Control from 25 s: ~20 steps each way, so the commands in flight outlast the window by 20 steps.
    config = SEED.replace(curvature_radius_m=4.0, control_start_s=25.0)
    env = gym.make("LightSail-v0", config=config, light_delay=True, beam_jitter_m=1e-6, push_noise=1e-3)
    assert env.unwrapped.episode_spec.delay_steps(0) >= 20
    _, rewards, infos = _run(env, seed=0)
    assert len(rewards) == SEED.control_steps and np.isfinite(infos[-1]["terminal_pointing_rad"])


def test_planar_spec_defaults_are_those_of_the_default_env():
    """``planar_spec()`` (what a controller may design on) is the default ``LightSailEnv``'s task."""
    from sail_env.envs.planar import planar_spec

    default, env_spec = planar_spec(), LightSailEnv().episode_spec
    assert default.config == env_spec.config == SEED and default.randomisation == env_spec.randomisation and default.light_delay == env_spec.light_delay
    np.testing.assert_array_equal(default.action_scale, env_spec.action_scale)
    np.testing.assert_array_equal(default.start_half_widths, env_spec.start_half_widths)


@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSail3D-v0"])
def test_frames_show_the_window_from_reset_and_keep_the_sail_in_its_panel(env_id, monkeypatch):
    """Issue 20: the 3D envs had no rendering; the frame at reset had an empty panel with a
    meaningless time axis, ω had no unit, and at X = −44 mm the sail was drawn outside its panel."""
    from sail_env.envs import rendering

    drawn, original = [], rendering.SailRenderer._draw_sail

    def draw_sail(ax, view, state, beam_input) -> None:
        original(ax, view, state, beam_input)
        drawn.append(ax)
    monkeypatch.setattr(rendering.SailRenderer, "_draw_sail", staticmethod(draw_sail))
    env = gym.make(env_id, render_mode="rgb_array")
    spec = env.unwrapped.episode_spec
    start = {"x": -0.044, "theta" if "theta" in spec.plant.state_names else "theta_y": 1.5e-3}
    env.reset(seed=0, options={"initial_state": start})
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.std() > 0
    figure = env.unwrapped._renderer.figure
    track = figure.axes[-1]  # after the sail panels (x, and y in 3D)
    window = (spec.config.control_start_s, spec.config.control_start_s + spec.n_steps * spec.dt)
    assert track.get_xlim() == pytest.approx(window) and "rad/s" in track.get_title()
    sail_panel = drawn[-1]
    low, high = sail_panel.get_xlim()
    for line in sail_panel.get_lines():
        assert np.all((low <= line.get_xdata()) & (line.get_xdata() <= high))
    env.step(env.action_space.sample())
    assert env.render().shape == frame.shape
    env.close()


@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSail3D-v0"])
def test_an_unknown_keyword_is_named(env_id):
    """The keywords are spelled out once (core.spec.task_spec); a misspelt one is named, not swallowed."""
    with pytest.raises(TypeError, match="unexpected keyword argument 'beam_jiter_m'"):
        gym.make(env_id, beam_jiter_m=1e-3)
