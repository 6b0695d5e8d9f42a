"""A refused call changes nothing: after the ``ValueError`` of a bad ``reset`` or ``step`` (or the
``RuntimeError`` of a step on a finished episode) an env under ``gym.make``'s wrappers, and the vector
env, hold the same buffers and generators and play on exactly as one that never saw the call. And
actions of every real float dtype play as the same numbers in float64."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401  (registers the ids)
from sail_env.physics.planar.config import DEEP_DISH
from tests.envs.test_copies import assert_same

#: Every disturbance (its generator draws at reset and over the coast), on the planar sail: cheap.
ENV_ID = "LightSailRealistic-v0"
BAD_RESETS = [{"seed": 2, "options": {"bad": 1}}, {"seed": 2, "options": {"initial_state": {"x": math.nan}}},
              {"seed": 2, "options": {"initial_state": {"x": 10.0}}}, {"seed": 2, "options": [1]},
              {"seed": -1}, {"seed": 1.5},
              # options["params"] (sail_env.envs.options): a bad value, an unknown keyword, a space's change
              # (the light delay's, directly and through the timing), and good params with a refused start
              # or seed, which must not stay applied
              {"seed": 2, "options": {"params": {"push_noise": -0.1}}},
              {"seed": 2, "options": {"params": {"bogus": 1}}}, {"seed": 2, "options": {"params": 3}},
              {"seed": 2, "options": {"params": {"light_delay": False}}},
              {"seed": 2, "options": {"params": {"config": DEEP_DISH.replace(control_start_s=20.0)}}},
              {"seed": 2, "options": {"params": {"parameter_spread": 0.2}, "initial_state": {"x": 10.0}}},
              {"seed": -1, "options": {"params": {"parameter_spread": 0.2}}}]
VECTOR = pytest.mark.parametrize("vector", [False, True], ids=["gym.make", "vector"])


def _make(vector: bool) -> Any:
    return (gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point") if vector
            else gym.make(ENV_ID))


def _action(step: int, env: Any) -> np.ndarray:
    """A fixed action sequence that steers, in values every float dtype holds exactly (float16's)."""
    shape = env.action_space.shape
    return (0.6 * np.sin(0.31 * step + np.arange(np.prod(shape)))).reshape(shape).astype(np.float16)


def _snapshot(env: Any) -> tuple:
    """Everything a refused call could change: the episode state's buffers, every generator's state
    and the task (its spec, core and keywords, which ``options["params"]`` changes)."""
    unwrapped = env.unwrapped
    rngs = [unwrapped.np_random, *unwrapped.state.rngs, *(getattr(unwrapped, "_rngs", None) or ())]
    return (unwrapped.state.floats.tobytes(), unwrapped.state.ints.tobytes(),
            [None if rng is None else rng.bit_generator.state for rng in rngs],
            id(unwrapped.episode_spec), id(unwrapped.core), dict(unwrapped.keywords))


def _play_alike(env: Any, reference: Any, steps: range, dtype: type = np.float32) -> None:
    """Step both with the same actions, ``env``'s in ``dtype`` and the reference's in float64 (the
    single env resets when its episode ends): the same answers, bit for bit."""
    for step in steps:
        action = _action(step, env)
        result = env.step(action.astype(dtype))
        assert_same(result, reference.step(action.astype(np.float64)), f"step {step}")
        if result[2] is True:
            assert_same(env.reset(), reference.reset(), f"reset after step {step}")


@VECTOR
def test_a_refused_reset_changes_nothing(vector):
    env, reference = _make(vector), _make(vector)
    for bad in BAD_RESETS:  # the very first call refused: the env then starts as any other
        with pytest.raises(ValueError):
            env.reset(**bad)
    assert_same(env.reset(seed=1), reference.reset(seed=1), "reset")
    _play_alike(env, reference, range(5))
    before = _snapshot(env)
    for bad in BAD_RESETS:  # mid-episode: the refused seed must not reach the generator
        with pytest.raises(ValueError):
            env.reset(**bad)
        assert _snapshot(env) == before, bad
    _play_alike(env, reference, range(5, 260))  # past the end and a reset without a seed


@VECTOR
def test_a_refused_step_changes_nothing(vector):
    env, reference = _make(vector), _make(vector)
    assert_same(env.reset(seed=1), reference.reset(seed=1), "reset")
    _play_alike(env, reference, range(5))
    good = _action(5, env).astype(np.float64)
    before = _snapshot(env)
    for bad in (np.full_like(good, np.nan), np.where(np.arange(good.size).reshape(good.shape) == 1, np.inf, good),
                good[..., :-1], good.astype(bool), good.astype(complex), good.astype(str)):
        with pytest.raises(ValueError, match="action"):
            env.step(bad)
        assert _snapshot(env) == before, bad
    _play_alike(env, reference, range(5, 260))


def test_a_step_on_a_finished_episode_changes_nothing():
    env, reference = _make(False), _make(False)
    assert_same(env.reset(seed=1), reference.reset(seed=1), "reset")
    step, terminated = 0, False
    while not terminated:
        action = _action(step, env)
        terminated = env.step(action)[2]
        reference.step(action)
        step += 1
    before = _snapshot(env)
    with pytest.raises(RuntimeError, match="finished episode"):
        env.step(_action(step, env))
    assert _snapshot(env) == before
    assert_same(env.reset(), reference.reset(), "reset")
    _play_alike(env, reference, range(step, step + 10))


@VECTOR
@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.longdouble])
def test_actions_of_any_real_float_dtype_play_as_float64(vector, dtype):
    env, reference = _make(vector), _make(vector)
    assert_same(env.reset(seed=1), reference.reset(seed=1), "reset")
    _play_alike(env, reference, range(210), dtype)  # past the first end
