"""RL benchmark table: algorithms × planar tasks × training seeds, next to the classical baselines.

    python benchmarks/rl_table.py                                  # the full grid (hours on 2 cores)
    python benchmarks/rl_table.py --algos ppo --seeds 0 --timesteps 300000

Each run is ``train.py --algo A --env E --seed S --timesteps N`` (shipped hyperparameters,
``N`` defaults to their ``n_timesteps``) into ``OUT/runs/E-A-S``; finished runs are reused.
Every best model and the baselines (passive, and LQR or LQG) then play the same
``--episodes`` seeded episodes per task (evaluate.py's pairing). Reported per task and
algorithm: mean ± std over seeds of the success rate and of log10 of the median terminal
pointing, training steps, wall time per run. Writes ``OUT/rl_table.md`` and ``OUT/rl_table.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
from agents import evaluation as evaluate
from agents.sb3 import ALGOS, versions
from sail_env.tasks import TASKS

#: The classical reference per task: LQG where the observation is delayed and noisy.
REFERENCE = {"LightSail-v0": "lqr", "LightSailDeepDish-v0": "lqr", "LightSailRealistic-v0": "lqg"}


def train_run(algo: str, env_id: str, seed: int, timesteps: int | None, out: Path) -> Path:
    """Train one run with train.py (skipped if it already finished); its directory."""
    run_dir = out / "runs" / f"{env_id}-{algo}-{seed}"
    if (run_dir / "final_model.zip").is_file():
        return run_dir
    command = [sys.executable, str(ROOT / "train.py"), "--algo", algo, "--env", env_id, "--seed", str(seed),
               "--out", str(run_dir), "--no-progress-bar"]
    if timesteps is not None:
        command += ["--timesteps", str(timesteps)]
    log = run_dir.with_suffix(".log")
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("w") as file:
        subprocess.run(command, stdout=file, stderr=subprocess.STDOUT, check=True)
    return run_dir


def run_facts(run_dir: Path) -> dict[str, float]:
    """Training steps and wall time (all sessions) of a finished run."""
    sessions = json.loads((run_dir / "run.json").read_text())["sessions"]
    return {"timesteps": sessions[-1]["timesteps"], "wall_time_s": sum(s["wall_time_s"] for s in sessions)}


def log10_median(summary: dict[str, Any]) -> float:
    """log10 of the median terminal pointing (inf if most episodes diverged)."""
    median = summary["terminal_pointing_rad"]["median"]
    return float(np.log10(median)) if median is not None else float("inf")


def table_rows(env_id: str, summaries: dict[str, dict], runs: dict[str, list[Path]]) -> list[dict[str, Any]]:
    """One row per baseline and per algorithm (aggregated over its seeds)."""
    rows = []
    for name in ("passive", REFERENCE[env_id]):
        s = summaries[name]
        rows.append({"env": env_id, "agent": name, "seeds": 0, "success_mean": s["success_rate"], "success_std": 0.0,
                     "log10_pointing_mean": log10_median(s), "log10_pointing_std": 0.0})
    for algo, run_dirs in runs.items():
        per_seed = [summaries[name] for name in summaries if name.startswith(f"{algo}:{env_id}-{algo}-")]
        success = [s["success_rate"] for s in per_seed]
        pointing = [log10_median(s) for s in per_seed]
        facts = [run_facts(d) for d in run_dirs]
        rows.append({"env": env_id, "agent": algo, "seeds": len(per_seed),
                     "success_mean": float(np.mean(success)), "success_std": float(np.std(success)),
                     "log10_pointing_mean": float(np.mean(pointing)), "log10_pointing_std": float(np.std(pointing)),
                     "timesteps": int(np.mean([f["timesteps"] for f in facts])),
                     "wall_time_s": float(np.mean([f["wall_time_s"] for f in facts]))})
    return rows


def markdown(rows: list[dict[str, Any]], episodes: int, seed: int) -> str:
    lines = [f"Success rate (pointing ≤ 10 nrad) and log10 median terminal pointing [rad] on {episodes} paired "
             f"episodes (seeds {seed}…{seed + episodes - 1}); learners: mean ± std over training seeds, "
             "best model of each run (selected on separate episodes), wall time per run on 2 CPU cores.", "",
             "| task | agent | seeds | training steps | wall time | success rate | log10 pointing |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        learner = r["seeds"] > 0
        steps = f"{r['timesteps']:,}" if learner else "–"
        wall = f"{r['wall_time_s'] / 60:.1f} min" if learner else "–"
        success = f"{r['success_mean']:.1%}" + (f" ± {r['success_std']:.1%}" if learner else "")
        pointing = f"{r['log10_pointing_mean']:.2f}" + (f" ± {r['log10_pointing_std']:.2f}" if learner else "")
        lines.append(f"| {r['env']} | {r['agent']} | {r['seeds'] or '–'} | {steps} | {wall} | {success} | {pointing} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algos", nargs="+", choices=sorted(ALGOS), default=["ppo", "sac", "td3"])
    parser.add_argument("--envs", nargs="+", choices=list(TASKS), default=list(TASKS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--timesteps", type=int, help="fixed training budget (default: each YAML's n_timesteps)")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--seed", type=int, default=evaluate.DEFAULT_SEED, help="first evaluation episode seed")
    parser.add_argument("--jobs", type=int, default=2, help="training runs at a time (one core each)")
    parser.add_argument("--out", type=Path, default=Path("runs/benchmark"))
    args = parser.parse_args(argv)

    grid = [(algo, env_id, seed) for env_id in args.envs for algo in args.algos for seed in args.seeds]
    with ThreadPoolExecutor(args.jobs) as pool:
        run_dirs = list(pool.map(lambda job: train_run(*job, args.timesteps, args.out), grid))
    rows = []
    for env_id in args.envs:
        runs = {algo: [d for (a, e, _), d in zip(grid, run_dirs) if a == algo and e == env_id] for algo in args.algos}
        specs = ["passive", REFERENCE[env_id]] + [str(d / "best_model.zip") for ds in runs.values() for d in ds]
        results, _ = evaluate.evaluate(env_id, specs, args.episodes, args.seed)
        summaries = {name: evaluate.summarise(episodes) for name, episodes in results.items()}
        rows += table_rows(env_id, summaries, runs)
        print(markdown(rows, args.episodes, args.seed))
    table = markdown(rows, args.episodes, args.seed)
    (args.out / "rl_table.md").write_text(table)
    config = {k: v for k, v in vars(args).items() if k != "out"}
    standard = [{k: evaluate.finite_or_none(v) if isinstance(v, float) else v for k, v in r.items()} for r in rows]
    (args.out / "rl_table.json").write_text(json.dumps({"rows": standard, "config": config, "versions": versions()},
                                                       indent=2, allow_nan=False))
    print(f"written: {args.out / 'rl_table.md'}")


if __name__ == "__main__":
    main()
