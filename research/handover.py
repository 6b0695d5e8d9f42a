"""Where in the window a learner loses its points: it and the adaptive bank share the episode.

    python -m research.handover --policy runs/jax/<run>/best_policy.npz                # K = 10, 50 (about 8 min)
    python -m research.handover --policy ... --last 10 --episodes 50

A learner of ``train_jax.py`` and ``lqg-mm-offset`` (the best classical design on ``LightSailUncertain-v2``)
play seeded episodes together: one commands the window's first steps, the other its last ``K``. Both see
every observation; the bank's filters predict with the command that was sent, whichever of the two sent
it (its members' ``replace_last_command``), so the bank takes over with the state estimate it would have
had watching. The learner's memory is of observations, which show the commands sent, so it needs nothing.

For each ``K`` two orders are played:

- ``learner → bank``: the bank steers the last ``K`` steps (and holds its last command over the coast).
  If this scores as the bank alone, the learner's steering before them was good enough;
- ``bank → learner``: the learner steers the last ``K`` steps only. If this scores as the learner
  alone, the points are lost there.

Each alone is played too (its row ``K = 0``). The episodes are the same for every row (seeds 10,000 on,
apart from the README's). Prints a markdown table; its numbers are in docs/learners.md.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import sail_env  # noqa: F401
from agents.evaluation import make_agent
from agents.oracle import attach
from agents.sb3 import ModelLoadError
from research.action_noise import AGENT as BANK
from research.action_noise import ENV_ID, play_episodes


class Handover:
    """``first`` commands the window's steps before its last ``last``, ``second`` those; ``bank`` (one of
    them) is told every command sent. Episodes are played by :func:`agents.evaluation.run_episode`."""

    def __init__(self, first, second, bank, last: int, window: int, action_scale: np.ndarray) -> None:
        self.first, self.second, self.bank = first, second, bank
        self.switch, self.action_scale, self.step = window - last, action_scale, 0

    def attach(self, env: gym.Env) -> None:
        attach(self.first, env)
        attach(self.second, env)

    def reset(self) -> None:
        self.first.reset()
        self.second.reset()
        self.step = 0

    def act(self, observation: np.ndarray) -> np.ndarray:
        # Both act on every step, so that each keeps its memory of the episode; one is sent.
        actions = [np.asarray(agent.act(observation), np.float32) for agent in (self.first, self.second)]
        steering = self.step >= self.switch
        sent = np.clip(actions[steering], -1.0, 1.0)
        if (self.first, self.second)[steering] is not self.bank:  # the bank's filters predict with what was sent
            for member in self.bank.bank:
                member.replace_last_command(np.atleast_2d(sent * self.action_scale))
        self.step += 1
        return sent


def make_player(order: str, learner, bank, last: int, window: int, action_scale: np.ndarray):
    """The agent that plays ``order`` (``learner``, ``bank``: alone; ``learner-bank``, ``bank-learner``: the
    second steers the last ``last`` steps)."""
    if order in ("learner", "bank"):
        return learner if order == "learner" else bank
    first, second = (learner, bank) if order == "learner-bank" else (bank, learner)
    return Handover(first, second, bank, last, window, action_scale)


def play(policy: str, order: str, last: int, episodes: int) -> tuple[float, float]:
    """The success rate and the median terminal pointing [rad] of ``order`` (``learner``, ``bank``: alone;
    ``learner-bank``, ``bank-learner``: the second plays the last ``last`` steps)."""
    env = gym.make(ENV_ID)
    spec = env.unwrapped.episode_spec
    learner, bank = make_agent(policy, env), make_agent(BANK, env)
    agent = make_player(order, learner, bank, last, spec.n_steps, np.asarray(spec.action_scale))
    return play_episodes(env, agent, episodes)


def main(argv: list[str] | None = None) -> list[tuple[str, int, float, float]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", required=True, help="a policy.npz or best_policy.npz of train_jax.py")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--last", type=int, nargs="+", default=[10, 50], help="steps the second agent plays")
    args = parser.parse_args(argv)
    env = gym.make(ENV_ID)
    window = env.unwrapped.episode_spec.n_steps
    for last in args.last:
        if not 0 < last < window:
            parser.error(f"--last {last}: the window has {window} steps, K must be in [1, {window - 1}]")
    try:  # before the table's header: a policy that cannot be read is one line
        make_agent(args.policy, env)
    except (ModelLoadError, ValueError) as err:
        parser.error(f"--policy {err}")
    print(f"{ENV_ID}, {args.policy} and {BANK}, {args.episodes} episodes per row\n")
    print("| who steers | last K steps | success | median terminal pointing |")
    print("|---|---:|---:|---:|")
    cases = [("learner", 0), ("bank", 0)] + [(order, last) for last in args.last
                                             for order in ("learner-bank", "bank-learner")]
    rows = []
    for order, last in cases:
        rate, median = play(args.policy, order, last, args.episodes)
        rows.append((order, last, rate, median))
        print(f"| {order.replace('-', ' → ')} | {last or '–'} | {rate:.1%} | {median * 1e9:.2f} nrad |", flush=True)
    return rows


if __name__ == "__main__":
    main()
