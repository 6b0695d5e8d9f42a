"""Speed of the envs and of training, as ratios to a peer run in the same process, interleaved.

    python -m benchmarks.speed [--quick] [--rounds K] [--sections single vector ...] [--readme docs/performance.md]

These 2-core machines are shared and their CPUs differ, so no absolute speed here means much on
its own. Every ratio is subject ÷ peer where the two take turns (peer, subject, peer, subject, …,
``--rounds`` of each) and the best round of each counts: a neighbour's burst slows a round, never
speeds one up. Beside wall time each round records the thread's CPU time (``time.thread_time``),
which another process's load does not inflate; the tables give the wall-time ratio and, in brackets,
the CPU-time one.

Sections (``--sections``):

| section | subject | peer |
|---|---|---|
| ``single`` | each task's step through ``gym.make``, random actions, autoreset | CartPole-v1 |
| ``vector`` | ``gym.make_vec`` env-steps/s at N = 1, 64, 1024, 16384 (whole episodes) | ``CartPoleVectorEnv`` |
| ``episode`` | a passive ``LightSail3DRealistic-v1`` episode at N = 1, its slowest step, and both with the machine's BLAS threads ÷ one thread | — |
| ``ppo`` | SB3 PPO env-steps/s through ``agents.training.make_env`` (the task's shipped settings) | the same PPO on Pendulum-v1 |
| ``start`` | a new process's import and first step, with empty and warm caches (Numba's and the 3D tables') [s] | the same for CartPole-v1 |

Torch and BLAS run on one thread, as ``train.py`` runs them, except in the ``episode`` section's
comparison. Prints markdown tables, writes JSON (the CPU model, versions, every round) to ``--out``
and with ``--readme FILE`` puts the tables between that markdown file's ``speed-table`` markers
(``docs/performance.md``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv
from threadpoolctl import threadpool_limits

import sail_env  # noqa: F401
from agents import cli
from agents.sb3 import algo_kwargs, load_hyperparams, one_thread_per_process, versions
from agents.training import make_env
from sail_env.physics.memo import CACHE_VARIABLE
from sail_env.provenance import machine
from sail_env.tasks import TASKS

README_SECTION = "speed-table"
SECTIONS = ("single", "vector", "episode", "ppo", "start")
VECTOR_SIZES = (1, 64, 1024, 16384)
#: The realistic 3D task whose episode cost the ``episode`` section measures.
HARD_TASK = "LightSail3DRealistic-v1"
#: The realistic 3D tasks' coast costs ~0.1 s of CPU per episode: a round of whole episodes at
#: N = 1024 would take minutes, so their vector cells stop at this N ("–" beyond).
SLOW_TASKS = {"LightSail3DRealistic-v0", HARD_TASK, "LightSailUncertain-v0", "LightSailUncertain-v1",
              "LightSailUncertain-v2"}
SLOW_TASKS_MAX_ENVS = 64
#: What one process's start runs: import, make, reset and one step (the first compiles what it needs).
START_SCRIPT = ("import time; t = time.perf_counter(); import gymnasium as gym, numpy as np; import sail_env; "
                "env = gym.make({env!r}); env.reset(seed=0); env.step(env.action_space.sample()); "
                "print(time.perf_counter() - t)")

Workload = Callable[[], int]  # does a fixed chunk of work, returns how many units (steps) it did


def timed(work: Workload) -> tuple[float, float]:
    """Units per second of one run of ``work``: by wall time and by this thread's CPU time."""
    wall, cpu = time.perf_counter(), time.thread_time()
    units = work()
    wall, cpu = time.perf_counter() - wall, time.thread_time() - cpu
    return units / wall, units / max(cpu, 1e-9)


def interleaved(workloads: dict[str, Workload], rounds: int) -> dict[str, dict[str, object]]:
    """Run the workloads in turn, ``rounds`` times each (A, B, A, B, …); each one's best round by
    wall time and by CPU time, and every round's rates."""
    samples: dict[str, list[tuple[float, float]]] = {name: [] for name in workloads}
    for _ in range(rounds):
        for name, work in workloads.items():
            samples[name].append(timed(work))
    return {name: {"rate": max(s[0] for s in runs), "cpu_rate": max(s[1] for s in runs), "rounds": runs}
            for name, runs in samples.items()}


def ratio(subject: dict, peer: dict) -> str:
    """``wall (cpu)`` ratio of two :func:`interleaved` results, to two significant digits."""
    return f"{subject['rate'] / peer['rate']:.2g} ({subject['cpu_rate'] / peer['cpu_rate']:.2g})"


def episode_steps(env_id: str) -> int:
    """Steps of one whole episode of ``env_id`` and the autoreset step after it (CartPole: 200)."""
    if env_id not in TASKS:
        return 200
    return gym.make(env_id).unwrapped.episode_spec.n_steps + 1


# ---------------------------------------------------------------------- workloads
def single_workload(env_id: str, steps: int) -> Workload:
    """``steps`` steps of one env through ``gym.make`` with pre-drawn random actions, autoreset."""
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]

    def work() -> int:
        for action in actions:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        return steps
    return work


def vector_workload(envs: gym.vector.VectorEnv, steps: int) -> Workload:
    """``steps`` batched steps (autoreset inside the vector env); units are env-steps."""
    envs.reset(seed=0)
    envs.action_space.seed(0)
    actions = [envs.action_space.sample() for _ in range(steps)]

    def work() -> int:
        for action in actions:
            envs.step(action)
        return steps * envs.num_envs
    return work


def ppo_workload(env_id: str, hyperparams_of: str) -> Workload:
    """One rollout and update of SB3's PPO with ``hyperparams_of``'s shipped settings on ``env_id``
    (a task through ``agents.training.make_env``; a Gymnasium peer through SB3's own wrappers)."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    hp = load_hyperparams("ppo", hyperparams_of)
    n_envs, policy = hp.pop("n_envs"), hp.pop("policy")
    hp.pop("n_timesteps"), hp.pop("normalize")
    if env_id in TASKS:
        env = make_env(env_id, n_envs, 0, "batched", {}, hp["gamma"], training=True)
    else:
        env = VecNormalize(make_vec_env(env_id, n_envs, seed=0), gamma=hp["gamma"])
    model = PPO(policy, env, seed=0, device="cpu", **algo_kwargs(hp, env.action_space.shape[0]))
    rollout = model.n_steps * n_envs
    model.learn(rollout)  # warm-up: the first rollout and update

    def work() -> int:
        model.learn(rollout, reset_num_timesteps=False)
        return rollout
    return work


# ---------------------------------------------------------------------- sections
def single_section(rounds: int, episodes: int, tasks: tuple[str, ...]) -> tuple[dict, str]:
    lines = ["| env (single, `gym.make`) | × CartPole-v1 |", "|---|---:|"]
    result = {}
    for env_id in tasks:
        steps = episodes * episode_steps(env_id)
        runs = interleaved({"CartPole-v1": single_workload("CartPole-v1", steps),
                            env_id: single_workload(env_id, steps)}, rounds)
        result[env_id] = runs
        lines.append(f"| {env_id} | {ratio(runs[env_id], runs['CartPole-v1'])} |")
    return result, "\n".join(lines)


def vector_section(rounds: int, episodes: int, sizes: tuple[int, ...], tasks: tuple[str, ...]) -> tuple[dict, str]:
    lines = ["| N | " + " | ".join(tasks) + " |", "|---:|" + "---:|" * len(tasks)]
    result: dict[int, dict] = {}
    for n in sizes:
        cells = []
        for env_id in tasks:
            if env_id in SLOW_TASKS and n > SLOW_TASKS_MAX_ENVS:
                cells.append("–")
                continue
            steps = episodes * episode_steps(env_id)
            runs = interleaved({"CartPoleVectorEnv": vector_workload(CartPoleVectorEnv(num_envs=n), steps),
                                env_id: vector_workload(gym.make_vec(env_id, num_envs=n,
                                                                     vectorization_mode="vector_entry_point"), steps)},
                               rounds)
            result.setdefault(n, {})[env_id] = runs
            cells.append(ratio(runs[env_id], runs["CartPoleVectorEnv"]))
        lines.append(f"| {n} | " + " | ".join(cells) + " |")
    return result, "\n".join(lines)


def passive_episode(env: gym.Env, seed: int) -> tuple[float, float]:
    """Wall time [s] of a passive episode (reset included) and of its slowest step."""
    start = time.perf_counter()
    env.reset(seed=seed)
    zero, slowest, done = np.zeros(env.action_space.shape, dtype=np.float32), 0.0, False
    while not done:
        step = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(zero)
        slowest = max(slowest, time.perf_counter() - step)
        done = terminated or truncated
    return time.perf_counter() - start, slowest


def episode_section(rounds: int) -> tuple[dict, str]:
    """A passive hard-task episode at N = 1, with one BLAS thread and with the machine's count, in turn."""
    env = gym.make(HARD_TASK)
    passive_episode(env, 0)  # builds what the first episode builds once
    times: dict[str, list[tuple[float, float]]] = {"one": [], "all": []}
    for seed in range(rounds):
        for label, threads in (("one", 1), ("all", os.cpu_count())):
            with threadpool_limits(threads):
                times[label].append(passive_episode(env, seed))
    best = {label: (min(t[0] for t in runs), min(t[1] for t in runs)) for label, runs in times.items()}
    result = {"env": HARD_TASK, "rounds": times, "episode_s": best["one"][0], "slowest_step_s": best["one"][1],
              "threads": os.cpu_count(), "episode_ratio": best["all"][0] / best["one"][0],
              "slowest_step_ratio": best["all"][1] / best["one"][1]}
    lines = [f"| a passive `{HARD_TASK}` episode, N = 1 | one BLAS thread | {os.cpu_count()} threads ÷ one |",
             "|---|---:|---:|",
             f"| whole episode (reset, window, coast) | {1e3 * best['one'][0]:.1f} ms | {result['episode_ratio']:.2f} |",
             f"| slowest step | {1e3 * best['one'][1]:.1f} ms | {result['slowest_step_ratio']:.2f} |"]
    return result, "\n".join(lines)


def ppo_section(rounds: int, tasks: tuple[str, ...]) -> tuple[dict, str]:
    lines = ["| PPO (the task's shipped settings, batched envs) | × the same PPO on Pendulum-v1 |", "|---|---:|"]
    result = {}
    for env_id in tasks:
        runs = interleaved({"Pendulum-v1": ppo_workload("Pendulum-v1", env_id),
                            env_id: ppo_workload(env_id, env_id)}, rounds)
        result[env_id] = runs
        lines.append(f"| {env_id} | {ratio(runs[env_id], runs['Pendulum-v1'])} |")
    return result, "\n".join(lines)


def start_seconds(env_id: str, cache_dir: str) -> float:
    """A new process's import, ``gym.make``, reset and first step [s], with ``cache_dir`` as Numba's cache
    and the 3D tables' (:mod:`sail_env.physics.memo`)."""
    environment = {**os.environ, "NUMBA_CACHE_DIR": cache_dir, CACHE_VARIABLE: cache_dir}
    script = START_SCRIPT.format(env=env_id)
    done = subprocess.run([sys.executable, "-c", script], env=environment, capture_output=True, text=True, check=True)
    return float(done.stdout.strip().splitlines()[-1])


def start_section(rounds: int, tasks: tuple[str, ...]) -> tuple[dict, str]:
    """Cold (empty caches) and warm starts of each task's process, beside CartPole-v1's."""
    lines = ["| a new process: import, make, reset, first step | empty cache | warm cache |", "|---|---:|---:|"]
    result = {}
    for env_id in ("CartPole-v1", *tasks):
        cold, warm = [], []
        for _ in range(rounds):
            with tempfile.TemporaryDirectory() as cache:
                cold.append(start_seconds(env_id, cache))
                warm.append(start_seconds(env_id, cache))
        result[env_id] = {"cold_s": min(cold), "warm_s": min(warm)}
        lines.append(f"| {env_id} | {min(cold):.2f} s | {min(warm):.2f} s |")
    return result, "\n".join(lines)


# ---------------------------------------------------------------------- command line
def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = cli.Parser(description=cli.describe(__doc__), formatter_class=cli.HelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="one episode per round, two rounds (one start), N up to 64: a check that it runs, "
                             "not a measurement")
    parser.add_argument("--rounds", type=cli.positive_int, default=5, help="turns of each workload (best counts)")
    parser.add_argument("--episodes", type=cli.positive_int, default=4, help="whole episodes per round")
    parser.add_argument("--sections", nargs="+", choices=SECTIONS, default=list(SECTIONS), help="what to measure")
    parser.add_argument("--tasks", nargs="+", choices=sorted(TASKS), default=list(TASKS),
                        help="single, vector and start sections: the tasks")
    parser.add_argument("--sizes", nargs="+", type=cli.positive_int, default=list(VECTOR_SIZES),
                        help="vector section: the numbers of envs")
    parser.add_argument("--ppo-tasks", nargs="+", choices=sorted(TASKS), default=["LightSail-v0", HARD_TASK],
                        help="ppo section: the tasks")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/speed.json"), help="JSON of every round")
    parser.add_argument("--readme", type=Path, help="put the tables between this markdown file's speed-table markers")
    args = parser.parse_args(argv)
    cli.distinct(args.sections, "--sections")
    cli.distinct(args.sizes, "--sizes")
    cli.distinct(args.tasks, "--tasks")
    args.start_rounds = min(args.rounds, 3)
    if args.quick:
        args.rounds, args.episodes, args.start_rounds = 2, 1, 1
        args.sizes = [n for n in args.sizes if n <= 64]
    return args


def main(argv: list[str] | None = None) -> int:
    try:
        args = parse_args(argv)
        cli.check_writable_dir(args.out.parent, "--out")
        if args.readme is not None:
            cli.readme_around_section(args.readme, README_SECTION)
    except cli.UsageError as err:
        return cli.fail(err)
    one_thread_per_process()
    result: dict[str, object] = {"machine": machine(), "versions": versions(), "rounds": args.rounds,
                                 "episodes_per_round": args.episodes}
    tasks = tuple(args.tasks)
    runners = {"single": lambda: single_section(args.rounds, args.episodes, tasks),
               "vector": lambda: vector_section(args.rounds, args.episodes, tuple(args.sizes), tasks),
               "episode": lambda: episode_section(args.rounds),
               "ppo": lambda: ppo_section(args.rounds, tuple(args.ppo_tasks)),
               "start": lambda: start_section(args.start_rounds, tasks)}
    tables = [f"Measured on {result['machine']['cpu']} ({result['machine']['cpus']} cores), "
              f"{time.strftime('%Y-%m-%d')}: wall-time ratio (thread-CPU-time ratio), best of {args.rounds} "
              f"interleaved rounds."]
    for section in args.sections:
        result[section], table = runners[section]()
        tables.append(table)
        print(table + "\n", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cli.write_whole(args.out, json.dumps(result, indent=2))
    if args.readme is not None:
        cli.replace_readme_section(args.readme, README_SECTION, "\n\n".join(tables))
    return 0


if __name__ == "__main__":
    sys.exit(main())
