"""The ceiling, measured: passive, LQR, LQG and the two oracles (agents/oracle.py) on paired episodes,
each agent's paired difference to LQG with a 95 % interval (docs/physics.md §16).

    python -m benchmarks.ceiling                                   # both realistic tasks, 200 episodes
    python -m benchmarks.ceiling --env LightSailUncertain-v1 --agent lqg-robust --episodes 400
    python -m benchmarks.ceiling --env LightSailRealistic-v0 --agent runs/X/best_model.zip --episodes 500

Every agent plays episodes ``seed … seed + n − 1`` (``evaluate.py``'s runner and default seeds), so
the comparison is paired. For agent A against LQG: the difference of success rates, a 95 % paired
bootstrap interval (episodes resampled together, 10,000 resamples, fixed seed) and McNemar's exact
two-sided p-value on the discordant pairs (A wins where LQG loses: ``b``; the reverse: ``c``).
Results go to ``--out`` (JSON, rewritten after every agent, so a long run keeps what it measured); agents
run again on the same episodes are added to (or replace) that task's earlier rows.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import sail_env  # noqa: F401
from agents import cli
from agents.evaluation import BASELINES, DEFAULT_SEED, make_agent, paired_difference, run_agent, summarise
from agents.sb3 import one_thread_per_process

DEFAULT_ENVS = ("LightSailRealistic-v0", "LightSail3DRealistic-v1")
DEFAULT_AGENTS = ("passive", "lqr", "lqg", "lqg-oracle", "lqr-oracle")
REFERENCE = "lqg"


def measure(env_id: str, agents: list[str], episodes: int, seed: int, out: Path, results: dict[str, Any],
            env_kwargs: dict[str, Any] | None = None, key: str | None = None) -> dict[str, Any]:
    """Run ``agents`` on ``env_id`` (with ``env_kwargs``) and store the rows under ``results[key]``
    (default: the env id), writing ``out`` after every agent."""
    key = key or env_id
    fresh = {"env": env_id, "env_kwargs": {k: repr(v) for k, v in (env_kwargs or {}).items()}, "episodes": episodes,
             "seed": seed, "agents": {}}
    if {k: v for k, v in results.get(key, {}).items() if k != "agents"} != {k: v for k, v in fresh.items()
                                                                           if k != "agents"}:
        results[key] = fresh  # other episodes: start afresh; the same ones: add agents to them
    entry = results[key]
    env = gym.make(env_id, **(env_kwargs or {}))
    outcomes: dict[str, np.ndarray] = {}
    for name in agents:
        start = time.perf_counter()
        played = run_agent(env_id, make_agent(name, env), episodes, seed, progress=False, env_kwargs=env_kwargs)
        outcomes[name] = np.array([e["success"] for e in played])
        entry["agents"][name] = {**summarise(played), "seconds": round(time.perf_counter() - start, 1),
                                 "success": outcomes[name].astype(int).tolist()}
        if REFERENCE in entry["agents"]:
            reference = np.array(entry["agents"][REFERENCE]["success"], bool)
            for other, row in entry["agents"].items():
                if other != REFERENCE:
                    row["vs_lqg"] = paired_difference(np.array(row["success"], bool), reference)
        cli.write_whole(out, json.dumps(results, indent=1, allow_nan=False))
        print(f"{key} {name}: {outcomes[name].mean():.1%}", flush=True)
    return entry


def table(entry: dict[str, Any]) -> str:
    """Markdown rows: agent, success with its Wilson interval, the paired difference to LQG."""
    lines = ["| agent | success | 95 % CI | vs LQG (paired) | 95 % CI | McNemar p |", "|---|---:|---:|---:|---:|---:|"]
    for name, row in entry["agents"].items():
        lo, hi = row["success_ci95"]
        vs = row.get("vs_lqg")
        paired = ("–", "–", "–") if vs is None else (f"{100 * vs['difference']:+.1f} pts",
                                                       f"{100 * vs['ci95'][0]:+.1f} … {100 * vs['ci95'][1]:+.1f}",
                                                       f"{vs['mcnemar_p']:.2g}")
        lines.append(f"| {name} | {row['success_rate']:.1%} | {lo:.1%}–{hi:.1%} | " + " | ".join(paired) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", action="append", help=f"task ids (default: {', '.join(DEFAULT_ENVS)})")
    parser.add_argument("--agent", action="append",
                        help=f"{', '.join(sorted(BASELINES))} or a model .zip saved by train.py "
                             f"(default: {', '.join(DEFAULT_AGENTS)})")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED)
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/ceiling.json"))
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be >= 1, got {args.episodes}")
    one_thread_per_process()
    results = json.loads(args.out.read_text()) if args.out.is_file() else {}
    agents = args.agent or list(DEFAULT_AGENTS)
    for env_id in args.env or DEFAULT_ENVS:
        have = results.get(env_id, {})
        if REFERENCE not in agents and not (REFERENCE in have.get("agents", {}) and have["episodes"] == args.episodes
                                            and have["seed"] == args.seed):
            agents.insert(0, REFERENCE)
        entry = measure(env_id, agents, args.episodes, args.seed, args.out, results)
        print(f"\n{env_id}: {args.episodes} paired episodes (seeds {args.seed}…{args.seed + args.episodes - 1})\n")
        print(table(entry), flush=True)


if __name__ == "__main__":
    main()
