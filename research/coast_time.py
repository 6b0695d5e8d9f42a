"""What a hard task's plant costs: a passive episode at N = 1, and a batch's coast with the machine's
default BLAS threads against one (docs/physics.md §14, "The flight table", "BLAS threads").

    python -m research.coast_time [--task LightSail3DRealistic-v1] [--rounds 5] [--out PATH]

Two measures, each interleaved (A, B, A, B, …; best of the rounds) so that a shared machine's load
falls on both alike:

* ``episode_ms``: a passive episode (zero action) of ``--task`` through ``gym.make`` at N = 1, best
  of ``--rounds`` (seeds 1, 2, …), and the thread CPU time beside it.
* ``blas``: a 64-environment vector env's episode (its last step carries the coast) with the BLAS
  libraries at their default thread count against ``threadpool_limits(1)`` around the whole episode;
  their ratio must stay below 1.5 (issue 18's goal), which the plant's own one-thread limit
  (:mod:`sail_env.physics.blas`) ensures.

To compare two trees (before/after a change), run the script from each alternately with
``--episode-only`` and compare the printed bests. Writes a JSON beside the printout
(``research/results/coast_time.json`` by default).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

import sail_env  # noqa: F401
from sail_env.provenance import machine

RESULTS = Path(__file__).parent / "results"


def passive_episode(env, seed: int) -> tuple[float, float]:
    """Wall and thread CPU seconds of one passive episode (reset included)."""
    wall, cpu = time.perf_counter(), time.thread_time()
    env.reset(seed=seed)
    action = np.zeros(env.action_space.shape, np.float32)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(action)
        done = bool(np.all(terminated | truncated))
    return time.perf_counter() - wall, time.thread_time() - cpu


def vector_episode(env, seed: int) -> float:
    """Wall seconds of one episode of a vector env whose environments all end together."""
    start = time.perf_counter()
    env.reset(seed=seed)
    action = np.zeros(env.action_space.shape, np.float32)
    while True:
        _, _, terminated, truncated, _ = env.step(action)
        if np.all(terminated | truncated):
            return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="LightSail3DRealistic-v1")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--batch", type=int, default=64)
    parser.add_argument("--episode-only", action="store_true")
    parser.add_argument("--out", type=Path, default=RESULTS / "coast_time.json")
    args = parser.parse_args()

    env = gym.make(args.task)
    passive_episode(env, 0)  # warm-up (caches, first-call imports)
    runs = [passive_episode(env, seed) for seed in range(1, args.rounds + 1)]
    best = min(runs)
    out = {"machine": machine(), "task": args.task, "episode_ms": 1e3 * best[0], "episode_cpu_ms": 1e3 * best[1],
           "episode_ms_all": [1e3 * w for w, _ in runs]}
    print(f"{args.task} passive episode, N = 1: best {out['episode_ms']:.1f} ms wall, "
          f"{out['episode_cpu_ms']:.1f} ms thread CPU (all: {[round(x, 1) for x in out['episode_ms_all']]})")
    if not args.episode_only:
        vector = gym.make_vec(args.task, num_envs=args.batch, vectorization_mode="vector_entry_point")
        vector_episode(vector, 0)
        default, single = [], []
        for seed in range(1, args.rounds + 1):  # interleaved: default, one, default, one, …
            default.append(vector_episode(vector, seed))
            with threadpool_limits(1):
                single.append(vector_episode(vector, seed))
        out["blas"] = {"batch": args.batch, "default_threads": [i["num_threads"] for i in threadpool_info()],
                       "default_s": min(default), "one_thread_s": min(single), "ratio": min(default) / min(single)}
        print(f"{args.batch}-env episode: default BLAS threads {out['blas']['default_threads']} "
              f"{min(default):.2f} s, one thread {min(single):.2f} s, ratio {out['blas']['ratio']:.2f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
