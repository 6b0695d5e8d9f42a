"""A standing guard: configurations and disturbances drawn across the documented valid space, whole
episodes with random actions. Only a ValueError at construction is allowed; every observation is
finite and inside the space, every reward finite, every info complete.

CI runs a quick derandomized profile; ``python -m benchmarks.properties`` runs the same property
on many more random draws and prints a summary.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sail_env.physics.randomisation import MAX_PARAMETER_SPREAD, MAX_PUSH_NOISE
from sail_env.envs import LightSailEnv
from sail_env.physics import SEED

STEP_INFO = {"state", "t"}
TERMINAL_INFO = {"terminal_pointing_rad", "terminal_envelope_rad", "is_success", "diverged", "cutoff_s"}


@st.composite
def cases(draw) -> dict:
    """Keyword arguments of a planar env and an action seed, drawn from the documented limits."""
    spread = draw(st.floats(0.0, 0.9 * MAX_PARAMETER_SPREAD))
    widen = (1 + spread) / (1 - spread)  # the spread box (sail_env.physics.planar.plant)
    lc = draw(st.floats(5.0, 15.0))
    # Flat, unstable (Lc < R), neutral (R = Lc) and deep dishes down to R = a.
    radius = draw(st.one_of(st.just(math.inf), st.just(lc), st.floats(SEED.aperture_radius_m * widen, 4 * lc)))
    config = SEED.replace(curvature_radius_m=radius, com_distance_m=lc,
                          strut_length_m=lc * widen * draw(st.floats(1.001, 3.0)),  # 1.001: round-off
                          control_start_s=draw(st.one_of(st.just(0.0), st.floats(0.0, 20.0))),
                          control_window_s=draw(st.floats(0.005, 0.3)))
    fraction = st.one_of(st.just(0.0), st.floats(0.0, 0.01), st.floats(0.0, 1.0))  # of each maximum
    return {
        "config": config,
        "sensor_noise_std": tuple(draw(st.one_of(st.just(0.0), st.floats(0.0, scale)))
                                  for scale in (1.0, 1e2, 0.05, 1e2)),
        "beam_jitter_m": SEED.aperture_radius_m * draw(fraction),
        "push_noise": MAX_PUSH_NOISE * draw(fraction),
        "cutoff_jitter_s": draw(st.one_of(st.just(0.0), st.floats(0.0, 500.0))),
        "light_delay": draw(st.booleans()),
        "parameter_spread": spread,
        "action_seed": draw(st.integers(0, 2**16)),
    }


def check_episode(case: dict) -> str:
    """Run one episode of ``case``; returns how it ended ('refused', 'diverged', 'scored')."""
    kwargs = dict(case)
    rng = np.random.default_rng(kwargs.pop("action_seed"))
    try:
        env = LightSailEnv(**kwargs)
    except ValueError:
        return "refused"
    obs, info = env.reset(seed=int(rng.integers(2**31)))
    space = env.observation_space
    assert space.contains(obs) and np.all(np.isfinite(obs)) and STEP_INFO <= set(info)
    done = False
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        while not done:
            obs, reward, done, truncated, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            assert space.contains(obs) and np.all(np.isfinite(obs)) and math.isfinite(reward) and not truncated
            assert STEP_INFO <= set(info)
            assert info.get("diverged") or "envelope_rad" in info
    assert TERMINAL_INFO <= set(info)
    if info["diverged"]:
        assert info["terminal_pointing_rad"] == math.inf and not info["is_success"]
        return "diverged"
    assert math.isfinite(info["terminal_pointing_rad"]) and set(info["terminal_state"]) == {"x", "vx", "theta", "omega"}
    return "scored"


@settings(max_examples=150, deadline=None, derandomize=True)
@given(case=cases())
def test_every_valid_configuration_runs_a_clean_episode(case):
    check_episode(case)
