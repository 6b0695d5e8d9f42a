"""A standing guard for the 3D env (issue 20): every keyword drawn across its documented range (shapes x
beams x each keyword from zero to its limit), whole episodes with random actions. Only a ValueError at
construction is allowed; every observation is finite and inside the space, every reward finite, the
episode ends within the control window, the same seed plays the same numbers, and a vector env's
environment plays the single env's episode of its seed."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sail_env.envs.rigid3d import LightSail3DEnv, rigid3d_vector_env
from sail_env.physics.planar.config import SEED
from sail_env.physics.rigid3d.config import BEAM_PROFILES, MAX_CURVATURE_OVER_APERTURE, SHAPES, RigidSailConfig
from sail_env.physics.rigid3d.limits import MAX_POWER_CONTROL

A = SEED.aperture_radius_m


def _log_uniform(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(math.log(low), math.log(high)).map(math.exp)


@st.composite
def cases(draw) -> dict:
    """Keyword arguments of LightSail3DEnv and an action seed."""
    shape, beam = draw(st.sampled_from(SHAPES)), draw(st.sampled_from(BEAM_PROFILES))
    radius = draw(_log_uniform(A * 1.001, A * MAX_CURVATURE_OVER_APERTURE))
    lc = draw(st.floats(0.5, SEED.strut_length_m))
    low, high = RigidSailConfig(shape=shape, beam_profile=beam, curvature_radius_m=radius, com_distance_m=lc
                                ).beam_radius_range()
    off = st.just(0.0)
    kwargs = {
        "sail_shape": shape, "beam_profile": beam, "curvature_radius_m": radius, "com_distance_m": lc,
        "beam_radius_m": draw(st.one_of(st.none(), _log_uniform(max(low, 1e-3 * A), high))),
        "absorptivity": draw(st.one_of(off, st.floats(0.0, 1.0))),
        # A spinning unstable sail (a balloon of R = 28 m, Lc = 12 m at 10 rad/s, e.g.) overflowed the
        # envelope's look-ahead into a non-finite reward (found by this test; pointing.MAX_LOOKAHEAD_GROWTH).
        "spin_rad_s": draw(st.one_of(off, st.floats(-math.pi / SEED.control_step_s, math.pi / SEED.control_step_s))),
        "power_control": draw(st.one_of(st.booleans(), st.floats(0.0, MAX_POWER_CONTROL))),
        "relativistic": draw(st.booleans()), "velocity_terms": draw(st.booleans()),
        "ground_jitter_rad": draw(st.one_of(off, _log_uniform(1e-18, 2.8e-11))),
        "diffraction_length_m": draw(st.one_of(st.just(math.inf), _log_uniform(3e9, 1e11))),
        "payload_offset_m": draw(st.one_of(off, st.floats(0.0, A))),
        "control_start_s": draw(st.one_of(off, st.floats(0.0, 20.0))),
        "beam_jitter_m": draw(st.one_of(off, _log_uniform(1e-9, A))),
        "push_noise": draw(st.one_of(off, st.floats(0.0, 0.25))),
        "cutoff_jitter_s": draw(st.one_of(off, st.floats(0.0, 500.0))),
        "light_delay": draw(st.booleans()),
        "parameter_spread": draw(st.one_of(off, st.floats(0.0, 0.45))),
        "sensor_noise_std": tuple(draw(st.one_of(off, st.floats(0.0, scale))) for scale in (1e-2,) * 2 + (1.0,) * 2
                                  + (1e-3,) * 2 + (1e-1,) * 2),
    }
    if draw(st.booleans()):
        kwargs.update(dust_density_m3=draw(_log_uniform(1e-12, 1e-3)), dust_grain_mass_kg=draw(_log_uniform(1e-26, 1e-9)))
    return {**kwargs, "action_seed": draw(st.integers(0, 2**16))}


def play(env: LightSail3DEnv, seed: int, actions: np.ndarray) -> tuple[list[np.ndarray], list[float], dict]:
    """One episode: its observations, rewards and last info, checked step by step."""
    space, limit = env.observation_space, env.episode_spec.n_steps
    obs, _ = env.reset(seed=seed)
    observations, rewards, done = [obs], [], False
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        while not done:
            assert len(rewards) < limit, "the episode ends within the control window"
            obs, reward, done, truncated, info = env.step(actions[len(rewards)])
            assert space.contains(obs) and np.all(np.isfinite(obs)) and math.isfinite(reward) and not truncated
            observations.append(obs)
            rewards.append(reward)
    assert info["diverged"] or math.isfinite(info["terminal_pointing_rad"])
    return observations, rewards, info


def check_case(case: dict) -> str:
    """Two episodes of ``case`` with one seed; returns how they ended ('refused', 'diverged', 'scored')."""
    kwargs = dict(case)
    rng = np.random.default_rng(kwargs.pop("action_seed"))
    try:
        env = LightSail3DEnv(**kwargs)
    except ValueError:
        return "refused"
    actions = rng.uniform(-1, 1, (env.episode_spec.n_steps,) + env.action_space.shape).astype(np.float32)
    seed = int(rng.integers(2**31))
    first, again = play(env, seed, actions), play(env, seed, actions)
    np.testing.assert_array_equal(np.array(first[0]), np.array(again[0]))
    assert first[1] == again[1] and first[2]["terminal_pointing_rad"] == again[2]["terminal_pointing_rad"]
    check_vector_plays_the_single_episode(kwargs, seed, actions, first)
    return "diverged" if first[2]["diverged"] else "scored"


def check_vector_plays_the_single_episode(kwargs: dict, seed: int, actions: np.ndarray,
                                          single: tuple[list[np.ndarray], list[float], dict]) -> None:
    """Environment 1 of a vector env reset with ``seed − 1`` plays the single env's episode (seeded
    ``seed``) to the last bit, whatever environment 0 does beside it."""
    envs = rigid3d_vector_env(num_envs=2, **kwargs)
    obs, _ = envs.reset(seed=seed - 1)
    observations, rewards = [obs[1]], []
    for step, action in enumerate(actions[:len(single[1])]):
        obs, reward, terminated, _, info = envs.step(np.stack([-action, action]))
        rewards.append(reward[1])
        observations.append(info["final_obs"][1] if terminated[1] else obs[1])
        if terminated[1]:
            assert info["final_info"]["terminal_pointing_rad"][1] == single[2]["terminal_pointing_rad"]
            break
    np.testing.assert_array_equal(np.array(observations), np.array(single[0]))
    assert rewards == single[1]


@settings(max_examples=40, deadline=None, derandomize=True)
@given(case=cases())
def test_every_valid_3d_configuration_runs_clean_repeatable_episodes(case):
    check_case(case)


def test_a_model_that_outgrows_its_coast_pieces_diverges_cleanly() -> None:
    """A case newer Hypothesis versions draw (annulus beam, L0 = e^22 m): far beyond L0 the dish's
    model grows faster than the window's, a coast piece's exponential overflowed, and the episode
    raised FloatingPointError under the test's error state instead of ending diverged."""
    case = {"sail_shape": "dish", "beam_profile": "annulus", "curvature_radius_m": math.exp(0.75),
            "com_distance_m": 9.0, "beam_radius_m": 1.0, "absorptivity": 0.0, "spin_rad_s": 0.0,
            "power_control": False, "relativistic": False, "velocity_terms": False, "ground_jitter_rad": 0.0,
            "diffraction_length_m": math.exp(22.0), "payload_offset_m": 0.0, "control_start_s": 0.0,
            "beam_jitter_m": 0.0, "push_noise": 0.0, "cutoff_jitter_s": 0.0, "light_delay": False,
            "parameter_spread": 0.0, "sensor_noise_std": (0.0,) * 8, "action_seed": 0}
    assert check_case(case) == "diverged"
