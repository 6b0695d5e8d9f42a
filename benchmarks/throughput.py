"""Environment throughput, as a ratio to Gymnasium's CartPole-v1 measured in the same run.

    python benchmarks/throughput.py [--steps 20000]

Random actions, auto-reset, single process; prints a markdown table.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
from threadpoolctl import threadpool_limits

import sail_env  # noqa: F401
from sail_env.tasks import TASKS


def steps_per_second(env_id: str, steps: int, seed: int = 0) -> float:
    env = gym.make(env_id)
    env.reset(seed=seed)
    env.action_space.seed(seed)
    actions = [env.action_space.sample() for _ in range(steps)]
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000)
    args = parser.parse_args()
    threadpool_limits(1)  # as train.py and evaluate.py run the envs
    reference = steps_per_second("CartPole-v1", args.steps)
    print("| environment | steps/s | ratio to CartPole-v1 |")
    print("|---|---:|---:|")
    print(f"| CartPole-v1 | {reference:,.0f} | 1.00 |")
    for env_id in TASKS:
        rate = steps_per_second(env_id, args.steps)
        print(f"| {env_id} | {rate:,.0f} | {rate / reference:.2f} |")


if __name__ == "__main__":
    main()
