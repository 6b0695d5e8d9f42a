"""What limits the classical reference on LightSailRealistic-v0: each disturbance alone and all but it.

    python -m research.realistic_ablation [--agent lqg] [--episodes 200]   # from the repo root

Prints a markdown table of success rates over the same seeded episodes (evaluate.py's
episode runner), every other disturbance of the task switched off or on.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import sail_env  # noqa: F401
from agents.evaluation import BASELINES, DEFAULT_SEED, run_episode
from sail_env.tasks import REALISTIC_DISTURBANCES

ENV_ID = "LightSailRealistic-v0"
OFF = {"sensor_noise_std": (0.0, 0.0, 0.0, 0.0), "beam_jitter_m": 0.0, "push_noise": 0.0,
       "cutoff_jitter_s": 0.0, "light_delay": False, "parameter_spread": 0.0}


def success_rate(agent_name: str, episodes: int, env_id: str = ENV_ID, **disturbances) -> float:
    """Success of a classical agent on ``episodes`` paired episodes of ``env_id`` with keywords."""
    env = gym.make(env_id, **disturbances)
    agent = BASELINES[agent_name](env.unwrapped.episode_spec)
    return float(np.mean([run_episode(env, agent, DEFAULT_SEED + i)["success"] for i in range(episodes)]))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", choices=sorted(BASELINES), default="lqg")
    parser.add_argument("--episodes", type=int, default=200)
    args = parser.parse_args(argv)
    print(f"{args.agent} on {ENV_ID}, {args.episodes} episodes (seeds from {DEFAULT_SEED})\n")
    print("| disturbance | alone | all but it |")
    print("|---|---:|---:|")
    print(f"| none / all | {success_rate(args.agent, args.episodes, **OFF):.1%} "
          f"| {success_rate(args.agent, args.episodes):.1%} |")
    for name, value in REALISTIC_DISTURBANCES.items():
        alone = success_rate(args.agent, args.episodes, **{**OFF, name: value})
        all_but = success_rate(args.agent, args.episodes, **{name: OFF[name]})
        print(f"| {name} | {alone:.1%} | {all_but:.1%} |")


if __name__ == "__main__":
    main()
