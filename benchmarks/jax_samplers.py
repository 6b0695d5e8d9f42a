"""The two backends' samplers in distribution: one agent's success rate over fresh episodes of each.

    python -m benchmarks.jax_samplers --env LightSail3DRealistic-v1 --agent lqg --episodes 4000 \
        --out benchmarks/results/jax_samplers.json

JAX's keys cannot reproduce NumPy's streams, so the same agent (passive, LQR, LQG and, on the 3D tasks,
the adaptive banks ``lqg-mm`` and ``lqg-mm-offset``: the JAX policies are designed by the same code as the
NumPy agents) plays ``--episodes`` fresh episodes on the Numba vector env and on the JAX backend, and the
two success rates must agree within sampling error. Each environment's first episode counts.
``tests/jax/test_samplers.py`` runs this at 10⁴ episodes on the fast tasks; the realistic 3D tasks' coast
costs ~50 ms an episode on a CPU core, so their comparison is kept here and run in the background (each
result is added to ``--out`` as it comes).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np

import sail_env.jax
from agents import cli
from agents.evaluation import BASELINES
from agents.jax_policies import POLICIES


def numba_success(env_id: str, agent_name: str, episodes: int) -> float:
    """The agent's success rate over the first episode of ``episodes`` Numba environments (seed 0)."""
    envs = gym.make_vec(env_id, num_envs=episodes, vectorization_mode="vector_entry_point")
    agent = BASELINES[agent_name](envs.unwrapped.episode_spec)
    obs, _ = envs.reset(seed=0)
    success, ended = np.zeros(episodes, bool), np.zeros(episodes, bool)
    while not ended.all():
        obs, _, terminated, _, info = envs.step(agent.act(obs))
        if not terminated.any():
            continue
        first = terminated & ~ended
        success[first] = np.asarray(info["final_info"]["is_success"])[first]
        ended |= terminated
    envs.close()
    return float(success.mean())


def jax_success(env_id: str, agent_name: str, episodes: int) -> float:
    """The agent's success rate over the first episode of ``episodes`` JAX environments (:func:`first_episodes`)."""
    env, params = sail_env.jax.make(env_id)
    return float(first_episodes(env, params, agent_name, episodes)["is_success"].mean())


def first_episodes(env: sail_env.jax.SailEnv, params: sail_env.jax.EnvParams, agent_name: str, episodes: int,
                   seed: int = 1) -> dict[str, np.ndarray]:
    """Every environment's first episode through ``step_batch`` (its autoreset starts a second one,
    which is not counted), the policy's memory started afresh with each episode; the loop stops once
    every first episode has ended. Each first episode's ``is_success`` and ``expected_success``."""
    policy = POLICIES[agent_name](env.spec)
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(jax.random.key(seed), episodes), params)
    memory = jax.vmap(lambda _: policy.start())(jnp.arange(episodes))
    dtype = params.state_scale.dtype

    def one(carry, params):  # params an argument, not a constant of the program (the fast coast's maps: ~2 GB)
        obs, state, memory, success, expected, ended, key = carry
        key, step_key = jax.random.split(key)
        memory, action = jax.vmap(policy.act)(memory, obs)
        obs, state, _, terminated, _, info = env.step_batch(jax.random.split(step_key, episodes), state, action,
                                                            params)
        first = terminated & ~ended
        success = jnp.where(first, info["is_success"], success)
        expected = jnp.where(first, info["expected_success"], expected)
        return obs, state, memory, success, expected, ended | terminated, key

    start = (obs, state, memory, jnp.zeros(episodes, bool), jnp.full(episodes, jnp.nan, dtype),
             jnp.zeros(episodes, bool), jax.random.key(seed + 1))
    _, _, _, success, expected, _, _ = jax.jit(lambda c, params: jax.lax.while_loop(
        lambda c: ~jnp.all(c[5]), lambda c: one(c, params), c))(start, params)
    return {"is_success": np.asarray(success), "expected_success": np.asarray(expected)}


def keep_row(path: Path, row: dict) -> None:
    """``row`` added to the JSON list in ``path`` (written whole), in place of a row of the same env, agent and
    episodes."""
    key = (row["env"], row["agent"], row["episodes"])
    kept = json.loads(path.read_text()) if path.exists() else []
    cli.write_whole(path, json.dumps([*(r for r in kept if (r["env"], r["agent"], r["episodes"]) != key), row],
                                     indent=1) + "\n")


def standard_error(numba: float, jax_rate: float, episodes: int) -> float:
    """The standard error of the difference of two proportions of ``episodes`` each (pooled)."""
    pooled = (numba + jax_rate) / 2
    return math.sqrt(max(pooled * (1 - pooled), 1e-12) * 2 / episodes)


def main(argv: list[str] | None = None) -> int:
    parser = cli.Parser(prog="python -m benchmarks.jax_samplers", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter)
    parser.add_argument("--env", required=True, help="a task of sail_env.tasks.JAX_TASKS")
    parser.add_argument("--agent", action="append", choices=sorted(POLICIES), required=True)
    parser.add_argument("--episodes", type=int, default=4000)
    parser.add_argument("--out", type=Path, help="add each result to this JSON file")
    try:
        args = parser.parse_args(argv)
        if args.episodes < 1:
            raise cli.UsageError(f"--episodes must be >= 1, got {args.episodes}")
        if args.env not in sail_env.jax.JAX_TASKS:
            raise cli.UsageError(f"--env {args.env}: the JAX backend has {', '.join(sail_env.jax.JAX_TASKS)}")
        spec = gym.make(args.env).unwrapped.episode_spec
        for agent in args.agent:  # a design that refuses the task (the banks need a 3D sail) refuses here
            try:
                POLICIES[agent](spec)
            except ValueError as err:
                raise cli.UsageError(f"--agent {agent}: {err}") from None
    except cli.UsageError as err:
        return cli.fail(err)
    for agent in args.agent:
        start = time.perf_counter()
        numba = numba_success(args.env, agent, args.episodes)
        middle = time.perf_counter()
        jax_rate = jax_success(args.env, agent, args.episodes)
        error = standard_error(numba, jax_rate, args.episodes)
        row = {"env": args.env, "agent": agent, "episodes": args.episodes, "numba": numba, "jax": jax_rate,
               "difference_in_standard_errors": (jax_rate - numba) / error,
               "numba_seconds": round(middle - start, 1), "jax_seconds": round(time.perf_counter() - middle, 1),
               "date": time.strftime("%Y-%m-%d")}
        print(json.dumps(row), flush=True)
        if args.out:
            keep_row(args.out, row)
    return 0


if __name__ == "__main__":
    sys.exit(main())
