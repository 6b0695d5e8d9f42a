"""The two backends' samplers in distribution: JAX's keys cannot reproduce NumPy's streams, so the
same agent's success rate over 10⁴ fresh episodes of each backend must agree within sampling error
(passive and LQR as JAX policies designed by the same code as the NumPy agents)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("gymnax")

import jax.numpy as jnp  # noqa: E402

import sail_env.jax  # noqa: E402
from agents import LQRAgent, PassiveAgent  # noqa: E402
from agents.jax_policies import POLICIES  # noqa: E402

EPISODES = 10_000
NUMPY_AGENTS = {"passive": PassiveAgent, "lqr": LQRAgent}


def numba_success(env_id: str, agent_name: str) -> float:
    envs = gym.make_vec(env_id, num_envs=EPISODES, vectorization_mode="vector_entry_point")
    agent = NUMPY_AGENTS[agent_name](envs.unwrapped.episode_spec)
    obs, _ = envs.reset(seed=0)
    success, ended = np.zeros(EPISODES, bool), np.zeros(EPISODES, bool)
    while not ended.all():
        obs, _, terminated, _, info = envs.step(agent.act(obs))
        if not terminated.any():
            continue
        first = terminated & ~ended
        success[first] = np.asarray(info["final_info"]["is_success"])[first]
        ended |= terminated
    return success.mean()


def jax_success(env_id: str, agent_name: str) -> float:
    env, params = sail_env.jax.make(env_id)
    policy = POLICIES[agent_name](env.spec)
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(jax.random.key(1), EPISODES), params)

    def one(carry, _):
        obs, state, success, ended = carry
        obs, state, _, terminated, info = jax.vmap(env.step_env, in_axes=(None, 0, 0, None))(
            jax.random.key(0), state, policy(obs), params)
        success = jnp.where(terminated & ~ended, info["is_success"], success)
        return (obs, state, success, ended | terminated), None

    start = (obs, state, jnp.zeros(EPISODES, bool), jnp.zeros(EPISODES, bool))
    (_, _, success, ended), _ = jax.jit(lambda c: jax.lax.scan(one, c, None, params.max_steps_in_episode))(start)
    assert bool(ended.all())
    return float(success.mean())


@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSailDeepDish-v0"])
@pytest.mark.parametrize("agent_name", ["passive", "lqr"])
def test_success_rates_agree_in_distribution(env_id: str, agent_name: str) -> None:
    numba, jax_rate = numba_success(env_id, agent_name), jax_success(env_id, agent_name)
    # Two proportions of 10⁴ each: |difference| within 4 standard errors (p < 1e-4 by chance).
    pooled = (numba + jax_rate) / 2
    error = math.sqrt(max(pooled * (1 - pooled), 1e-12) * 2 / EPISODES)
    assert abs(numba - jax_rate) <= 4 * error, (numba, jax_rate)
    if agent_name == "lqr":
        assert numba == jax_rate == 1.0
    else:
        assert 0.3 < numba < 0.8
