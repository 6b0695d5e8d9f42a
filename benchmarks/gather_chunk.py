"""How many environments ``step_batch`` should coast or reset together on this platform.

    python -m benchmarks.gather_chunk [--env LightSailUncertain-v2] [--envs 256] [--chunks 8 32 256] [--rounds 3]
                                      [--out benchmarks/results/gather_chunk.json]

``step_batch`` gathers the episodes that end on a step and coasts (and resets) them
:data:`sail_env.jax.env.CHUNK` rows at a time, as many chunks as there are such episodes. A chunk costs
its full size whatever the number of rows it holds, so a large one wastes most when few episodes end on
a step: in training, once divergences have spread the episodes' ends over the window. Two cases, each a
jitted ``lax.scan`` of ``step_batch`` under the LQR (a JAX policy) at ``--envs`` environments:

| case | the episodes | steps per call | ends per step |
|---|---|---:|---|
| ``spread`` | each started at a random step of its window (``state.time``) | 20 | about N / 200 |
| ``together`` | all started at once | one window and a step | all on the last |

The chunk sizes take turns (8, 32, 256, 8, …, ``--rounds`` of each) and the best round of each counts;
the table gives env-steps/s and each size's ratio to the largest. The chunk size does not change the
results (``tests/jax/test_api.py``: ``step_batch`` equals ``vmap(step)`` to the bit on any platform).
On a CPU, run it on one core (``taskset -c 1``): XLA then runs one thread, as a training run pinned to
a core does (docs/performance.md: two XLA threads sharing cores with another process wait on each other).
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import jax
import jax.numpy as jnp

import sail_env.jax
import sail_env.jax.env as jax_env
from agents import cli
from agents.jax_policies import lqr_policy
from benchmarks.speed_jax import timed
from sail_env.provenance import machine

CASES = {"spread": 20, "together": None}  # steps per call; None: one window and a step


def rollout(env, params, envs: int, steps: int, spread: bool):
    """A jitted function of a key: ``steps`` LQR steps of ``envs`` environments through ``step_batch``;
    returns the episodes ended (so that nothing is optimised away). Traced with the chunk size
    :data:`sail_env.jax.env.CHUNK` holds for this platform when it is first called."""
    policy = lqr_policy(env.spec)

    def run(key):
        reset_key, time_key, steps_key = jax.random.split(key, 3)
        obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(reset_key, envs), params)
        if spread:
            window = params.max_steps_in_episode
            state = state.replace(time=jax.random.randint(time_key, (envs,), 0, window).astype(state.time.dtype))

        def one(carry, key):
            obs, state, ended = carry
            _, action = jax.vmap(policy.act)(jnp.zeros(envs), obs)
            obs, state, _, done, _, _ = env.step_batch(jax.random.split(key, envs), state, action, params)
            return (obs, state, ended + done.sum(dtype=ended.dtype)), None

        return jax.lax.scan(one, (obs, state, jnp.zeros((), jnp.int32)), jax.random.split(steps_key, steps))[0][2]

    return jax.jit(run)


@contextlib.contextmanager
def chunk_size(platform: str, chunk: int) -> Iterator[None]:
    """:data:`sail_env.jax.env.CHUNK` set to ``chunk`` for ``platform`` inside the block."""
    kept = dict(jax_env.CHUNK)
    jax_env.CHUNK[platform] = chunk
    try:
        yield
    finally:
        jax_env.CHUNK.clear()
        jax_env.CHUNK.update(kept)


def main(argv: list[str] | None = None) -> int:
    parser = cli.Parser(prog="python -m benchmarks.gather_chunk", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter)
    parser.add_argument("--env", default="LightSailUncertain-v2", help="a task of the JAX backend")
    parser.add_argument("--envs", type=cli.positive_int, default=256, help="environments stepped together")
    parser.add_argument("--chunks", type=cli.positive_int, nargs="+", default=[8, 32, 256], help="chunk sizes")
    parser.add_argument("--rounds", type=cli.positive_int, default=3, help="interleaved rounds of each size")
    parser.add_argument("--out", type=Path, help="write the rates as JSON here (replaced whole)")
    args = parser.parse_args(argv)
    platform = jax.default_backend()
    env, params = sail_env.jax.make(args.env)
    rows = []
    print(f"{args.env}, N = {args.envs:,}, {jax.devices()[0].device_kind} ({platform}), JAX {jax.__version__}, "
          f"{time.strftime('%Y-%m-%d')}: best of {args.rounds} interleaved rounds", flush=True)
    print("\n| case | chunk | env-steps/s | ÷ the largest chunk's |\n|---|---:|---:|---:|", flush=True)
    for case, steps in CASES.items():
        steps = steps or params.max_steps_in_episode + 1
        functions, ended = {}, {}
        for chunk in args.chunks:
            functions[chunk] = rollout(env, params, args.envs, steps, spread=case == "spread")
            with chunk_size(platform, chunk):  # read when the function is traced, on its first call
                ended[chunk] = int(functions[chunk](jax.random.key(0)))
        best = {chunk: float("inf") for chunk in args.chunks}
        for r in range(args.rounds):
            for chunk, function in functions.items():
                best[chunk] = min(best[chunk], timed(function, jax.random.key(r + 1)))
        largest = args.envs * steps / best[max(args.chunks)]
        for chunk in args.chunks:
            rate = args.envs * steps / best[chunk]
            rows.append({"case": case, "chunk": chunk, "rate": rate, "steps": steps, "episodes_ended": ended[chunk]})
            print(f"| {case} | {chunk} | {rate:,.0f} | {rate / largest:.2f}× |", flush=True)
    if args.out:
        cli.write_whole(args.out, json.dumps({"env_id": args.env, "envs": args.envs, "rounds": args.rounds,
                                              "device": str(jax.devices()[0].device_kind), "machine": machine(),
                                              "cores_used": len(os.sched_getaffinity(0)),
                                              "jax": jax.__version__, "date": time.strftime("%Y-%m-%d"),
                                              "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
