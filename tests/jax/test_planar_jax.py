"""One task, two backends: the JAX planar env against the Numba core, fed the same draws.

JAX's random keys cannot reproduce NumPy's streams, so both backends are given the same launch
states and actions (the Numba core's ``initial_states``, the JAX env's ``reset_from``) over N = 256
environments and 1,000 steps with autoreset; observations must agree to the bit (under the XLA
flag of ``conftest.py``), rewards within 1e-12 and terminal pointing within 1e-9 (relative).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("gymnax")

import jax.numpy as jnp  # noqa: E402

import sail_env.jax  # noqa: E402
from sail_env.core.episode import EpisodeCore  # noqa: E402
from sail_env.envs.planar import planar_spec  # noqa: E402
from sail_env.tasks import PLANAR_TASKS  # noqa: E402

ENVS, STEPS = 256, 1000
EXACT = "--xla_cpu_max_isa=AVX" in os.environ.get("XLA_FLAGS", "")


def _launches(spec, rng: np.random.Generator, count: int) -> np.ndarray:
    """Launch states: most inside the task's box, one in eight near the start limits (some of
    those leave the beam within the window, so divergence and its early reset are exercised)."""
    box = spec.start_half_widths * rng.uniform(-1, 1, (count, spec.plant.n_states))
    wide = spec.start_limits * rng.uniform(-0.98, 0.98, (count, spec.plant.n_states))
    return np.where((rng.random(count) < 0.125)[:, None], wide, box)


@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSailDeepDish-v0"])
def test_the_same_draws_play_the_same_episodes(env_id: str) -> None:
    spec = planar_spec(**PLANAR_TASKS[env_id])
    core = EpisodeCore(spec, ENVS)
    env, params = sail_env.jax.make(env_id)
    reset = jax.jit(jax.vmap(env.reset_from, in_axes=(0, None)))
    step = jax.jit(jax.vmap(env.step_env, in_axes=(None, 0, 0, None)))
    select = jax.jit(lambda done, new, old: jax.tree.map(
        lambda a, b: jnp.where(done.reshape(done.shape + (1,) * (a.ndim - 1)), a, b), new, old))
    rng = np.random.default_rng(0)
    everyone = np.arange(ENVS)
    launch = _launches(spec, rng, ENVS)
    core.reset(everyone, [np.random.default_rng(i) for i in everyone], launch)
    obs, state = reset(jnp.asarray(launch), params)
    _assert_observations(np.asarray(obs), core.observe())
    key = jax.random.key(0)
    scored = diverged = 0
    for _ in range(STEPS):
        action = rng.uniform(-1.2, 1.2, (ENVS, spec.plant.n_inputs))  # beyond ±1: the clip too
        result = core.step(action)
        obs, state, reward, terminated, info = step(key, state, jnp.asarray(action), params)
        _assert_observations(np.asarray(obs), result.observation)
        np.testing.assert_array_equal(np.asarray(terminated), result.terminated.astype(bool))
        np.testing.assert_allclose(np.asarray(reward), result.reward, rtol=1e-12, atol=0)
        ended = np.flatnonzero(result.terminated)
        if len(ended):
            np.testing.assert_array_equal(np.asarray(info["diverged"])[ended], result.diverged[ended].astype(bool))
            np.testing.assert_allclose(np.asarray(info["terminal_pointing_rad"])[ended],
                                       result.terminal_pointing_rad[ended], rtol=1e-9, atol=0)
            np.testing.assert_array_equal(np.asarray(info["is_success"])[ended], result.success[ended])
            scored += int(np.sum(~result.diverged[ended].astype(bool)))
            diverged += int(np.sum(result.diverged[ended]))
            launch = _launches(spec, rng, len(ended))
            core.reset(ended, [np.random.default_rng(int(i)) for i in ended], launch)
            full = np.zeros((ENVS, spec.plant.n_states))
            full[ended] = launch
            new_obs, new_state = reset(jnp.asarray(full), params)
            done = np.zeros(ENVS, dtype=bool)
            done[ended] = True
            state = select(jnp.asarray(done), new_state, state)
            _assert_observations(np.asarray(select(jnp.asarray(done), new_obs, obs))[ended], core.observe(ended))
    assert scored > ENVS and diverged > 0, (scored, diverged)


def _assert_observations(jax_obs: np.ndarray, numba_obs: np.ndarray) -> None:
    if EXACT:
        np.testing.assert_array_equal(jax_obs.view(np.uint32), numba_obs.view(np.uint32))
    else:
        np.testing.assert_allclose(jax_obs, numba_obs, rtol=1e-6, atol=0)


def test_float32_keeps_the_scores_to_its_rounding() -> None:
    """The float32 option against float64 on the same launches and actions (1,024 episodes): the
    terminal pointing to 1e-4 in the median (the coast's ~4·10⁴ rad of phase costs float32 its
    digits; at worst ~1 %), success decided alike in all but a handful of episodes."""
    envs = 1024
    launch = _launches(planar_spec(**PLANAR_TASKS["LightSail-v0"]), np.random.default_rng(3), envs)
    actions = np.random.default_rng(4).uniform(-0.3, 0.3, (200, envs, 2))
    scores = []
    for dtype in (jnp.float64, jnp.float32):
        env, params = sail_env.jax.make("LightSail-v0", dtype=dtype)
        _, state = jax.vmap(env.reset_from, in_axes=(0, None))(jnp.asarray(launch, dtype), params)

        def one(state, action):
            _, state, reward, _, info = jax.vmap(env.step_env, in_axes=(None, 0, 0, None))(
                jax.random.key(0), state, action, params)
            return state, (reward, info["terminal_pointing_rad"], info["is_success"])

        reward, pointing, success = jax.jit(lambda s: jax.lax.scan(one, s, jnp.asarray(actions, dtype)))(state)[1]
        assert reward.dtype == dtype
        scores.append((np.asarray(reward, np.float64), np.asarray(pointing[-1], np.float64), np.asarray(success[-1])))
    (reward64, pointing64, success64), (reward32, pointing32, success32) = scores
    scored = np.isfinite(pointing64)  # the launches near the limits diverge (inf) in both
    np.testing.assert_array_equal(np.isfinite(pointing32), scored)
    error = np.abs(pointing32[scored] - pointing64[scored]) / pointing64[scored]
    assert np.median(error) < 1e-4 and error.max() < 0.05
    assert np.abs(reward32 - reward64).max() < 1e-2
    assert 0.1 < success64.mean() < 0.9 and np.sum(success32 != success64) <= envs // 100
