"""The same seeds under two OpenBLAS kernels: every noisy task must play the same episodes.

    python -m benchmarks.cross_kernel [--episodes 200] [--kernels default Prescott] [--agent passive]

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
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from agents import cli
from agents.evaluation import BASELINES, DEFAULT_SEED, run_agent
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD
from sail_env.provenance import machine, package_versions

#: The tasks with noise (sensor, jitter, push, dust, parameter spread, cut-off time).
NOISY_TASKS = ("LightSailRealistic-v0", "LightSail3DRealistic-v0", "LightSail3DRealistic-v1")
#: Below this relative difference of the terminal pointing the two kernels play the same episodes.
SAME_EPISODES = 1e-6
RESULTS = Path(__file__).parent / "results"


def play(tasks: list[str], agent_name: str, episodes: int) -> dict:
    """The child: each task's terminal pointings, and the BLAS kernels this process runs."""
    out = {"kernels": sorted({f"{i['internal_api']}:{i.get('architecture')}" for i in threadpool_info()})}
    with threadpool_limits(1):
        for task in tasks:
            agent = BASELINES[agent_name](gym.make(task).unwrapped.episode_spec)
            out[task] = [e["terminal_pointing_rad"] for e in run_agent(task, agent, episodes, DEFAULT_SEED, progress=False)]
    return out


def run_child(kernel: str, tasks: list[str], agent: str, episodes: int) -> dict:
    env = dict(os.environ)
    if kernel != "default":
        env["OPENBLAS_CORETYPE"] = kernel
    command = [sys.executable, "-m", "benchmarks.cross_kernel", "--child", "--agent", agent,
               "--episodes", str(episodes), "--tasks", *tasks]
    done = subprocess.run(command, env=env, capture_output=True, text=True, check=True,
                          cwd=Path(__file__).parents[1])
    return json.loads(done.stdout)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--kernels", nargs=2, default=("default", "Prescott"), metavar=("A", "B"),
                        help="OPENBLAS_CORETYPE of each child ('default': this machine's environment)")
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
    print("| task | largest relative difference of the terminal pointing | successes that differ |")
    print("|---|---:|---:|")
    summary = {"agent": args.agent, "episodes": args.episodes, "kernels": [first["kernels"], second["kernels"]],
               "tasks": {}}
    for task in args.tasks:
        a, b = np.array(first[task]), np.array(second[task])
        finite = np.isfinite(a) & np.isfinite(b)  # a diverged episode's pointing is inf
        a_f, b_f = a[finite], b[finite]
        relative = float(np.max(np.abs(a_f - b_f) / np.maximum(np.abs(a_f), np.abs(b_f)), initial=0.0))
        flipped = int(np.sum((a <= POINTING_TOLERANCE_RAD) != (b <= POINTING_TOLERANCE_RAD)))
        same_divergence = bool(np.array_equal(np.isfinite(a), np.isfinite(b)))
        summary["tasks"][task] = {"max_relative_difference": relative, "success_flips": flipped,
                                  "same_divergences": same_divergence}
        print(f"| {task} | {relative:.1e} | {flipped} |")
    worst = max(t["max_relative_difference"] for t in summary["tasks"].values())
    print(f"\nlargest: {worst:.1e} ({'below' if worst < SAME_EPISODES else 'ABOVE'} {SAME_EPISODES:g}: "
          f"{'the same episodes' if worst < SAME_EPISODES else 'not the same episodes'})")
    summary.update(machine=machine(), versions=package_versions("numpy", "scipy"))
    cli.write_whole(args.out / f"cross_kernel_{args.agent}.json", json.dumps(summary, indent=1) + "\n")
    return summary


if __name__ == "__main__":
    main()
