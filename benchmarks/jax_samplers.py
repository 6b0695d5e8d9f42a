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
    """Every environment's first episode through ``step_batch`` (its autoreset starts a second one,
    which is not counted), the policy's memory started afresh with each episode; the loop stops once
    every first episode has ended."""
    env, params = sail_env.jax.make(env_id)
    policy = POLICIES[agent_name](env.spec)
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(jax.random.key(1), episodes), params)
    memory = jax.vmap(lambda _: policy.start())(jnp.arange(episodes))

    def one(carry):
        obs, state, memory, success, ended, key = carry
        key, step_key = jax.random.split(key)
        memory, action = jax.vmap(policy.act)(memory, obs)
        obs, state, _, terminated, _, info = env.step_batch(jax.random.split(step_key, episodes), state, action,
                                                            params)
        success = jnp.where(terminated & ~ended, info["is_success"], success)
        return obs, state, memory, success, ended | terminated, key

    start = (obs, state, memory, jnp.zeros(episodes, bool), jnp.zeros(episodes, bool), jax.random.key(2))
    success = jax.jit(lambda c: jax.lax.while_loop(lambda c: ~jnp.all(c[4]), one, c)[3])(start)
    return float(success.mean())


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
            kept = json.loads(args.out.read_text()) if args.out.exists() else []
            kept = [r for r in kept if (r["env"], r["agent"], r["episodes"]) != (args.env, agent, args.episodes)]
            cli.write_whole(args.out, json.dumps([*kept, row], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
