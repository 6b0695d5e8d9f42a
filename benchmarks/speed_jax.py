"""Speed of the JAX backend against gymnax's ``CartPole-v1``, in one process, interleaved.

    python -m benchmarks.speed_jax [--quick] [--sizes 1000 10000 ...] [--tasks ID ...] [--rounds K] [--out FILE]
                                   [--readme FILE]
    python -m benchmarks.speed_jax --fast-coast 4096 --rounds 2 --out benchmarks/results/speed_jax_fast_coast.json

Each subject and the peer run the same loop: ``jit`` of a ``lax.scan`` over the batched step
(autoreset inside the step) with uniform random actions drawn inside the loop, N environments,
``--steps`` steps per call: the peer's ``vmap(env.step)``, the subject's ``step_batch`` (the same
results as its ``vmap(step)``, with the coast and the resets computed only on the steps that need
them). They take turns (peer, subject, peer, subject, …, ``--rounds`` of
each) and the best round of each counts: a neighbour's burst slows a round, never speeds one up.
The table gives env-steps/s and the ratio subject ÷ peer at each N, on whatever device JAX finds
(its name and the CPU model are printed). A second table sets the JAX backend against the
project's Numba vector env (``gym.make_vec(..., vectorization_mode="vector_entry_point")``) at
N = 1,024, interleaved the same way, and against the backend's own ``vmap(env.step)``.
Compilation is timed apart (the first call), and so is
a new process's cold start of the JAX path: import, ``make``, compile and the first step of one
environment. With ``--readme FILE`` the tables go between that markdown file's ``jax-speed-table``
markers (the README).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import jax
import jax.numpy as jnp

import sail_env.jax
from agents import cli
from sail_env.provenance import machine

SUBJECTS = ("LightSail-v0", "LightSailDeepDish-v0", "LightSailRealistic-v0", "LightSail3D-v0")
#: The realistic 3D task and the uncertain one, whose coasts follow the flight (~50 ms of CPU an episode on
#: either backend): on a CPU only against the Numba vector env at N = 1,024 (``--along``), without the
#: ``vmap(step)`` column, which would coast every environment at every step.
ALONG_SUBJECTS = ("LightSail3DRealistic-v1", "LightSailUncertain-v2")
#: Environments of the comparison with the Numba vector env.
NUMBA_ENVS = 1024
SIZES = (1_000, 10_000, 100_000, 1_000_000)
README_SECTION = "jax-speed-table"
#: A new process's first step on the JAX path (its time printed by the process itself).
COLD_START = """
import time
start = time.perf_counter()
import jax
import sail_env.jax
env, params = sail_env.jax.make("LightSail-v0")
obs, state = env.reset(jax.random.key(0), params)
jax.block_until_ready(env.step(jax.random.key(1), state, jax.numpy.zeros(2), params))
print(time.perf_counter() - start)
"""


def rollout(env, params, envs: int, steps: int, continuous: bool, batched: bool = True):
    """A jitted function of a key: ``steps`` autoresetting steps of ``envs`` environments (the
    backend's ``step_batch`` for a sail unless not ``batched``, gymnax's ``vmap(step)`` otherwise);
    returns the rewards' sum (so that nothing is optimised away). ``params`` enter the program as an
    argument, not as its constants (the fast coast's maps are ~2 GB)."""
    step = getattr(env, "step_batch", None) if batched else None
    step = step or jax.vmap(env.step, in_axes=(0, 0, 0, None))

    def run(key, params):
        obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(key, envs), params)

        def one(carry, key):
            state, total = carry
            act_key, step_key = jax.random.split(key)
            if continuous:
                action = jax.random.uniform(act_key, (envs, env.num_actions), minval=-1.0, maxval=1.0)
            else:
                action = jax.random.randint(act_key, (envs,), 0, 2)
            _, state, reward, _, _, _ = step(jax.random.split(step_key, envs), state, action, params)
            return (state, total + reward.sum()), None

        (_, total), _ = jax.lax.scan(one, (state, jnp.zeros(())), jax.random.split(key, steps))
        return total

    compiled = jax.jit(run)
    return lambda key: compiled(key, params)


def timed(function, *args) -> float:
    """Seconds of one call, its results waited for."""
    start = time.perf_counter()
    jax.block_until_ready(function(*args))
    return time.perf_counter() - start


def numba_rollout(env_id: str, envs: int, steps: int):
    """The Numba vector env's loop of ``steps`` autoresetting steps with uniform random actions (drawn
    before the timed part); a function of a seed, as :func:`rollout`'s of a key."""
    import gymnasium as gym
    import numpy as np

    vector = gym.make_vec(env_id, num_envs=envs, vectorization_mode="vector_entry_point")
    vector.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (steps, envs, *vector.single_action_space.shape))
    actions = actions.astype(np.float32)

    def run(seed: int) -> float:
        total = 0.0
        for action in actions:
            total += float(vector.step(action)[1].sum())
        return total

    return run


def numba_timed(function, seed: int) -> float:
    start = time.perf_counter()
    function(seed)
    return time.perf_counter() - start


def cold_start_s() -> float:
    """Seconds a new Python process takes from ``import jax`` to its first step of ``LightSail-v0``."""
    done = subprocess.run([sys.executable, "-c", COLD_START], capture_output=True, text=True, check=True)
    return float(done.stdout.strip().splitlines()[-1])


def along_rates(sizes: list[int], steps: int, rounds: int, rows: list[dict]) -> None:
    """:data:`ALONG_SUBJECTS`' env-steps/s through ``step_batch`` at each N (best of ``rounds``; each call
    a whole window, so every episode's coast is in it), printed and added to ``rows``."""
    for task in ALONG_SUBJECTS:
        env, params = sail_env.jax.make(task)
        for envs in sizes:
            subject = rollout(env, params, envs, steps, continuous=True)
            compile_s = timed(subject, jax.random.key(0))
            best = min(timed(subject, jax.random.key(r + 1)) for r in range(rounds))
            rows.append({"task": task, "envs": envs, "rate": envs * steps / best, "compile_s": compile_s})
            print(f"| {task} | {envs:,} | {envs * steps / best:.3g} env-steps/s | compile {compile_s:.1f} s |",
                  flush=True)


def fast_coast_table(sizes: list[int], steps: int, rounds: int, rows: list[dict], tasks: tuple[str, ...] = ALONG_SUBJECTS,
                     on_row: Callable[[], None] = lambda: None) -> list[str]:
    """``tasks`` on the fast coast (``coast="fast"``) against the default coast at each N, in one process,
    interleaved (default, fast, …; best of ``rounds``); each call a whole window, so every episode's coast is
    in it. The table's lines (printed as they come), each row added to ``rows`` (then ``on_row()``)."""
    lines = ["", "The fast coast against the default coast (one process, interleaved, `step_batch`):", "",
             "| task | N | default env-steps/s | fast env-steps/s | fast ÷ default | fast's build [s] |",
             "|---|---:|---:|---:|---:|---:|"]
    print("\n".join(lines), flush=True)
    for task in tasks:
        env, params = sail_env.jax.make(task)
        start = time.perf_counter()
        fast_env, fast_params = sail_env.jax.make(task, coast="fast")
        build_s = time.perf_counter() - start
        for envs in sizes:
            default, fast = (rollout(e, p, envs, steps, continuous=True) for e, p in ((env, params),
                                                                                       (fast_env, fast_params)))
            timed(default, jax.random.key(0))
            timed(fast, jax.random.key(0))
            best_default = best_fast = float("inf")
            for r in range(rounds):
                best_default = min(best_default, timed(default, jax.random.key(r + 1)))
                best_fast = min(best_fast, timed(fast, jax.random.key(r + 1)))
            rate, fast_rate = envs * steps / best_default, envs * steps / best_fast
            rows.append({"task": task, "envs": envs, "default_rate": rate, "fast_rate": fast_rate,
                         "fast_build_s": build_s, "fast_draws": int(fast_params.acceleration.shape[0])})
            lines.append(f"| {task} | {envs:,} | {rate:.3g} | {fast_rate:.3g} | {fast_rate / rate:.1f}× | {build_s:.0f} |")
            print(lines[-1], flush=True)
            on_row()
    return lines


def numba_table(tasks: tuple[str, ...], steps: int, rounds: int, rows: list[dict]) -> list[str]:
    """The JAX backend against the Numba vector env at N = :data:`NUMBA_ENVS` (one process, interleaved,
    best of ``rounds``), and against its own ``vmap(env.step)`` except for :data:`ALONG_SUBJECTS`: the
    table's lines (printed as they come), each row added to ``rows``."""
    lines = ["", f"Against the project's Numba vector env at N = {NUMBA_ENVS:,} (one process, the same interleaving):",
             "",
             "| task | JAX env-steps/s | Numba env-steps/s | JAX ÷ Numba | JAX through `vmap(step)` "
             "| `step_batch` ÷ it |",
             "|---|---:|---:|---:|---:|---:|"]
    print("\n".join(lines), flush=True)
    for task in tasks:
        env, params = sail_env.jax.make(task)
        subject = rollout(env, params, NUMBA_ENVS, steps, continuous=True)
        timed(subject, jax.random.key(0))
        vmapped = None
        if task not in ALONG_SUBJECTS:
            vmapped = rollout(env, params, NUMBA_ENVS, steps, continuous=True, batched=False)
            timed(vmapped, jax.random.key(0))
        numba = numba_rollout(task, NUMBA_ENVS, steps)
        numba_timed(numba, 0)  # compiles the kernels, fills the cache
        best_numba = best_subject = best_vmapped = float("inf")
        for r in range(rounds):
            best_numba = min(best_numba, numba_timed(numba, r + 1))
            best_subject = min(best_subject, timed(subject, jax.random.key(r + 1)))
            if vmapped is not None:
                best_vmapped = min(best_vmapped, timed(vmapped, jax.random.key(r + 1)))
        rate, numba_rate, vmapped_rate = (NUMBA_ENVS * steps / best
                                          for best in (best_subject, best_numba, best_vmapped))
        rows.append({"task": task, "envs": NUMBA_ENVS, "rate": rate, "numba_rate": numba_rate,
                     "vmapped_rate": vmapped_rate if vmapped is not None else None})
        versus = f"{vmapped_rate:.3g} | {rate / vmapped_rate:.1f}×" if vmapped is not None else "– | –"
        lines.append(f"| {task} | {rate:.3g} | {numba_rate:.3g} | {rate / numba_rate:.2f}× | {versus} |")
        print(lines[-1], flush=True)
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=SIZES)
    parser.add_argument("--steps", type=int, default=200, help="steps per timed call (default 200)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--tasks", nargs="+", choices=SUBJECTS + ALONG_SUBJECTS,
                        help=f"the tasks of the tables (default: {', '.join(SUBJECTS)}; with --fast-coast "
                             f"{', '.join(ALONG_SUBJECTS)})")
    parser.add_argument("--quick", action="store_true", help="N = 10^3 and 10^4, 2 rounds")
    parser.add_argument("--out", type=Path, help="write every round as JSON here")
    parser.add_argument("--readme", type=Path, help="put the tables between this markdown file's markers")
    parser.add_argument("--along", action="store_true",
                        help=f"only {', '.join(ALONG_SUBJECTS)} against the Numba vector env at N = {NUMBA_ENVS:,}")
    parser.add_argument("--along-sizes", type=int, nargs="+",
                        help=f"only {', '.join(ALONG_SUBJECTS)}'s own rate at these N (an accelerator's figure)")
    parser.add_argument("--fast-coast", type=int, nargs="+", metavar="N",
                        help=f"only {', '.join(ALONG_SUBJECTS)}: the fast coast against the default at these N")
    args = parser.parse_args(argv)
    for flag, sizes in (("--sizes", args.sizes), ("--fast-coast", args.fast_coast), ("--along-sizes", args.along_sizes)):
        if sizes and min(sizes) < 1:
            return cli.fail(cli.UsageError(f"{flag}: N must be >= 1, got {min(sizes)}"))
    for flag, value in (("--steps", args.steps), ("--rounds", args.rounds)):
        if value < 1:
            return cli.fail(cli.UsageError(f"{flag} must be >= 1, got {value}"))
    if args.fast_coast:
        tasks = tuple(args.tasks or ALONG_SUBJECTS)
        if set(tasks) - set(ALONG_SUBJECTS):
            return cli.fail(cli.UsageError(f"--tasks: the fast coast is for {', '.join(ALONG_SUBJECTS)}"))
        rows: list[dict] = []

        def keep() -> None:  # every row as it comes: an interrupted run keeps the rows it measured
            if args.out:
                cli.write_whole(args.out, json.dumps({
                    "device": str(jax.devices()[0].device_kind), "machine": machine(), "jax": jax.__version__,
                    "steps": args.steps, "rounds": args.rounds, "date": time.strftime("%Y-%m-%d"),
                    "command": " ".join(["python -m benchmarks.speed_jax", *(sys.argv[1:] if argv is None else argv)]),
                    "rows": rows}, indent=1))

        fast_coast_table(args.fast_coast, args.steps, args.rounds, rows, tasks, keep)
        return 0
    args.tasks = tuple(args.tasks or SUBJECTS)
    if set(args.tasks) - set(SUBJECTS):
        return cli.fail(cli.UsageError(f"--tasks: the main table's are {', '.join(SUBJECTS)}"))
    if args.readme:
        try:
            cli.readme_around_section(args.readme, README_SECTION)
        except cli.UsageError as err:
            return cli.fail(err)
    if args.quick:
        args.sizes, args.rounds = [1_000, 10_000], 2
    if args.along or args.along_sizes:
        rows = []
        if args.along_sizes:
            along_rates(args.along_sizes, args.steps, args.rounds, rows)
        else:
            numba_table(ALONG_SUBJECTS, args.steps, args.rounds, rows)
        if args.out:
            cli.write_whole(args.out, json.dumps({"device": str(jax.devices()[0].device_kind), "machine": machine(),
                                                  "jax": jax.__version__, "steps": args.steps, "rows": rows}, indent=1))
        return 0
    import gymnax

    peer_env, peer_params = gymnax.make("CartPole-v1")
    device = jax.devices()[0]
    lines = [f"Measured on {device.device_kind} ({device.platform}; CPU: {machine()['cpu']}, {machine()['cpus']} cores), "
             f"JAX {jax.__version__}, {time.strftime('%Y-%m-%d')}: best of {args.rounds} interleaved rounds of "
             f"{args.steps} steps, float64.", "",
             "| task | N | env-steps/s | gymnax CartPole-v1 env-steps/s | ratio | compile [s] |",
             "|---|---:|---:|---:|---:|---:|"]
    print("\n".join(lines), flush=True)
    rows = []
    for envs in args.sizes:
        peer = rollout(peer_env, peer_params, envs, args.steps, continuous=False)
        peer_compile = timed(peer, jax.random.key(0))
        for task in args.tasks:
            env, params = sail_env.jax.make(task)
            subject = rollout(env, params, envs, args.steps, continuous=True)
            compile_s = timed(subject, jax.random.key(0))
            best_peer = best_subject = float("inf")
            for r in range(args.rounds):
                best_peer = min(best_peer, timed(peer, jax.random.key(r + 1)))
                best_subject = min(best_subject, timed(subject, jax.random.key(r + 1)))
            rate, peer_rate = envs * args.steps / best_subject, envs * args.steps / best_peer
            rows.append({"task": task, "envs": envs, "rate": rate, "peer_rate": peer_rate,
                         "compile_s": compile_s, "peer_compile_s": peer_compile})
            lines.append(f"| {task} | {envs:,} | {rate:.3g} | {peer_rate:.3g} | {rate / peer_rate:.2f}× | {compile_s:.1f} |")
            print(lines[-1], flush=True)
    lines += numba_table(tuple(args.tasks), args.steps, args.rounds, rows)
    cold = cold_start_s()
    lines += ["", f"A new process's import, make, compile and first step of `LightSail-v0`: {cold:.1f} s."]
    print(lines[-1])
    if args.readme:
        cli.replace_readme_section(args.readme, README_SECTION, "\n".join(lines))
    if args.out:
        cli.write_whole(args.out, json.dumps({"device": str(device.device_kind), "machine": machine(),
                                              "jax": jax.__version__, "steps": args.steps, "rows": rows,
                                              "cold_start_s": cold}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
