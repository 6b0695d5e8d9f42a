"""The same seeds under two OpenBLAS kernels: every noisy task must play the same episodes.

    python -m benchmarks.cross_kernel [--episodes 200] [--kernels default Prescott] [--agent passive]
    python -m benchmarks.cross_kernel --kernels unset Haswell --agent lqg-mm-offset --tasks LightSailUncertain-v2

BLAS kernels (chosen by the CPU, or by ``OPENBLAS_CORETYPE``) round the last bits of a product
differently. A draw from a Gaussian must not amplify that: with ``V √Λ ξ`` from an
eigen-decomposition it did (an eigenvector's sign flipped between kernels and a terminal pointing
moved by 2 %, up to 170 % over 200 episodes); with the symmetric root it is round-off
(docs/physics.md §3). This script runs the same episodes (evaluate.py's runner, seeds from its
default) of every noisy task in one child process per kernel, ``OPENBLAS_CORETYPE`` set for that
child alone (``default``: as this machine's environment has it), and prints, per task, the largest
relative difference of the terminal pointing between the two and how many successes differ. It
writes ``benchmarks/results/cross_kernel_<agent>.json`` with the kernels the children reported.

The passive sail (open loop: the same actions whatever is observed) measures the env's own
reproducibility, which must stay below :data:`SAME_EPISODES`. A feedback agent adds the
observation's float32 rounding: a difference of 1e-11 in the state now and then rounds an
observation to the neighbouring float32 (6e-8 apart), the agent acts on it, and the episode moves
by that much more (LQG on ``LightSail3DRealistic-v1``: 1.6e-5, no success changed).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from agents import cli
from agents.evaluation import BASELINES, BATCH_EPISODES, DEFAULT_SEED, run_batch
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD
from sail_env.provenance import machine, package_versions

#: The tasks with noise (sensor, jitter, push, dust, parameter spread, cut-off time).
NOISY_TASKS = ("LightSailRealistic-v0", "LightSail3DRealistic-v0", "LightSail3DRealistic-v1", "LightSailUncertain-v2")
#: The two children's kernels by default: this machine's and the generic one (results without a suffix).
DEFAULT_KERNELS = ("default", "Prescott")
#: Below this relative difference of the terminal pointing the two kernels play the same episodes.
SAME_EPISODES = 1e-6
RESULTS = Path(__file__).parent / "results"


def play(tasks: list[str], agent_name: str, episodes: int) -> dict:
    """The child: each task's terminal pointings and window rewards (the terminal step's left out: it
    holds the pointing), and the BLAS kernels this process runs."""
    out = {"kernels": sorted({f"{i['internal_api']}:{i.get('architecture')}" for i in threadpool_info()})}
    with threadpool_limits(1):
        for task in tasks:
            agent = BASELINES[agent_name](gym.make(task).unwrapped.episode_spec)
            played = [episode for first in range(0, episodes, BATCH_EPISODES)
                      for episode in run_batch(task, agent, min(BATCH_EPISODES, episodes - first),
                                               DEFAULT_SEED + first, rewards=True)]
            out[task] = {"pointing": [e["terminal_pointing_rad"] for e in played],
                         "window_rewards": [e["rewards"][:-1] for e in played]}
    return out


def largest_reward_difference(first: list[list[float]], second: list[list[float]]) -> float:
    """The largest absolute difference of a window's reward over the episodes (inf where an episode's
    window is not as long under both kernels)."""
    return max((float(np.max(np.abs(np.subtract(a, b)), initial=0.0)) if len(a) == len(b) else math.inf
                for a, b in zip(first, second)), default=0.0)


def child_environment(kernel: str) -> dict[str, str]:
    """This process's environment with ``kernel``: ``default`` as it is, ``unset`` without
    ``OPENBLAS_CORETYPE`` and ``OPENBLAS_L2_SIZE`` (OpenBLAS picks the CPU's own kernel), else that
    ``OPENBLAS_CORETYPE``."""
    env = dict(os.environ)
    if kernel == "unset":
        env.pop("OPENBLAS_CORETYPE", None)
        env.pop("OPENBLAS_L2_SIZE", None)
    elif kernel != "default":
        env["OPENBLAS_CORETYPE"] = kernel
    return env


def run_child(kernel: str, tasks: list[str], agent: str, episodes: int) -> dict:
    env = child_environment(kernel)
    command = [sys.executable, "-m", "benchmarks.cross_kernel", "--child", "--agent", agent,
               "--episodes", str(episodes), "--tasks", *tasks]
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True,
                          cwd=Path(__file__).parents[1])
    return json.loads(done.stdout)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--kernels", nargs=2, default=DEFAULT_KERNELS, metavar=("A", "B"),
                        help="OPENBLAS_CORETYPE of each child ('default': this machine's environment; 'unset': "
                             "neither OPENBLAS_CORETYPE nor OPENBLAS_L2_SIZE)")
    parser.add_argument("--agent", default="passive", help="the classical agent that acts (passive, lqr, lqg)")
    parser.add_argument("--tasks", nargs="+", default=list(NOISY_TASKS))
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder of the results JSON")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        json.dump(play(args.tasks, args.agent, args.episodes), sys.stdout)
        return {}

    first, second = (run_child(kernel, args.tasks, args.agent, args.episodes) for kernel in args.kernels)
    print(f"{args.agent}, {args.episodes} episodes per task; kernels {args.kernels[0]} ({', '.join(first['kernels'])}) "
          f"and {args.kernels[1]} ({', '.join(second['kernels'])})\n")
    print("| task | largest relative difference of the terminal pointing | of a window's reward | successes that differ |")
    print("|---|---:|---:|---:|")
    summary = {"agent": args.agent, "episodes": args.episodes, "kernels": [first["kernels"], second["kernels"]],
               "tasks": {}}
    for task in args.tasks:
        a, b = np.array(first[task]["pointing"]), np.array(second[task]["pointing"])
        rewards = largest_reward_difference(first[task]["window_rewards"], second[task]["window_rewards"])
        finite = np.isfinite(a) & np.isfinite(b)  # a diverged episode's pointing is inf
        a_f, b_f = a[finite], b[finite]
        relative = float(np.max(np.abs(a_f - b_f) / np.maximum(np.abs(a_f), np.abs(b_f)), initial=0.0))
        flipped = int(np.sum((a <= POINTING_TOLERANCE_RAD) != (b <= POINTING_TOLERANCE_RAD)))
        same_divergence = bool(np.array_equal(np.isfinite(a), np.isfinite(b)))
        summary["tasks"][task] = {"max_relative_difference": relative, "max_window_reward_difference": rewards,
                                  "success_flips": flipped, "same_divergences": same_divergence}
        print(f"| {task} | {relative:.1e} | {rewards:.1e} | {flipped} |")
    worst = max(t["max_relative_difference"] for t in summary["tasks"].values())
    print(f"\nlargest: {worst:.1e} ({'below' if worst < SAME_EPISODES else 'ABOVE'} {SAME_EPISODES:g}: "
          f"{'the same episodes' if worst < SAME_EPISODES else 'not the same episodes'})")
    summary.update(machine=machine(), versions=package_versions("numpy", "scipy"))
    pair = "" if tuple(args.kernels) == DEFAULT_KERNELS else f"_{args.kernels[0]}-{args.kernels[1]}"
    cli.write_whole(args.out / f"cross_kernel_{args.agent}{pair}.json", json.dumps(summary, indent=1) + "\n")
    return summary


if __name__ == "__main__":
    main()
