"""How precisely the uncertain task must be steered: the adaptive bank with Gaussian errors on its actions.

    python -m research.action_noise                          # every step, ε = 0 … 0.03 (about 40 min)
    python -m research.action_noise --last 10 --sizes 0.01   # the window's last 10 steps only

``lqg-mm-offset`` (the best classical design on ``LightSailUncertain-v2``) plays seeded episodes with
``ε N(0, 1)`` added to each component of each action it asks for (the env then clips it to [-1, 1]),
on every step or on the window's last ``--last`` steps only. An error of that size is what a learnt
policy whose mean is off by ε makes; ε is in action units (1 is the full range: 2 cm of beam offset,
2 mrad of beam tilt). The errors' draws are the same for each size (one generator, seed 123, started
again per size), the episodes the same (seeds 10,000 on, apart from the README's). Prints a markdown
table; its numbers are in docs/learners.md ("Exploration noise, and the precision the task needs").
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import sail_env  # noqa: F401
from agents.evaluation import make_agent, run_episode
from agents.oracle import attach

ENV_ID = "LightSailUncertain-v2"
AGENT = "lqg-mm-offset"
FIRST_SEED = 10_000
NOISE_SEED = 123


class WithErrors:
    """``agent`` whose actions get ``size`` N(0, 1) errors (from ``rng``) on every step, or on the last
    ``last`` of the ``window``'s steps; the episodes are played by :func:`agents.evaluation.run_episode`."""

    def __init__(self, agent, size: float, last: int | None, window: int, rng: np.random.Generator) -> None:
        self.agent, self.size, self.rng = agent, size, rng
        self.first_noisy = 0 if last is None else window - last
        self.step = 0

    def attach(self, env: gym.Env) -> None:
        attach(self.agent, env)

    def reset(self) -> None:
        self.agent.reset()
        self.step = 0

    def act(self, observation: np.ndarray) -> np.ndarray:
        action = np.asarray(self.agent.act(observation), np.float64)
        if self.step >= self.first_noisy:
            action = action + self.size * self.rng.standard_normal(action.shape)
        self.step += 1
        return np.clip(action, -1.0, 1.0)


def success_with_errors(size: float, episodes: int, last: int | None) -> tuple[float, float]:
    """The success rate and the median terminal pointing [rad] with errors of ``size`` on every step's
    action (``last`` None) or on the last ``last`` steps of the window."""
    env = gym.make(ENV_ID)
    agent = WithErrors(make_agent(AGENT, env), size, last, env.unwrapped.episode_spec.n_steps,
                       np.random.default_rng(NOISE_SEED))
    return play_episodes(env, agent, episodes)


def play_episodes(env: gym.Env, agent, episodes: int) -> tuple[float, float]:
    """``agent``'s success rate and median terminal pointing [rad] on ``episodes`` seeded episodes from
    :data:`FIRST_SEED` (played by :func:`agents.evaluation.run_episode`)."""
    played = [run_episode(env, agent, seed) for seed in range(FIRST_SEED, FIRST_SEED + episodes)]
    return (float(np.mean([episode["success"] for episode in played])),
            float(np.nanmedian([episode["terminal_pointing_rad"] for episode in played])))


def main(argv: list[str] | None = None) -> list[tuple[float, float, float]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--last", type=int, help="errors on the window's last steps only (default: every step)")
    parser.add_argument("--sizes", type=float, nargs="+", default=[0.0, 0.001, 0.003, 0.01, 0.03],
                        help="the errors' standard deviations, in action units")
    args = parser.parse_args(argv)
    where = "every step" if args.last is None else f"the last {args.last} steps"
    print(f"{ENV_ID}, {AGENT} with errors on {where}'s actions, {args.episodes} episodes per size\n")
    print("| error's σ (action units) | success | median terminal pointing |")
    print("|---:|---:|---:|")
    rows = []
    for size in args.sizes:
        rate, median = success_with_errors(size, args.episodes, args.last)
        rows.append((size, rate, median))
        print(f"| {size:g} | {rate:.1%} | {median * 1e9:.2f} nrad |", flush=True)
    return rows


if __name__ == "__main__":
    main()
