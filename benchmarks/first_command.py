"""Time the README's main command, step by step, in a scratch directory.

    python -m benchmarks.first_command              # train.py + evaluate.py with this interpreter
    python -m benchmarks.first_command --install    # also a fresh venv and the README's pip lines

Runs ``python train.py --algo ppo`` and ``python evaluate.py --agent passive --agent lqr
--agent runs/latest/best_model.zip`` as a new user would (from the README), records the wall
time of each step, PPO's success rate, the machine and the versions, and writes
``benchmarks/results/first_command.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from agents import cli
from agents.sb3 import versions
from sail_env.provenance import machine

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "first_command.json"


def timed(command: list[str], cwd: Path) -> tuple[float, str]:
    """Wall time of ``command`` and its output (raises if it fails)."""
    start = time.perf_counter()
    run = subprocess.run(command, cwd=cwd, capture_output=True, text=True, check=False)
    if run.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed:\n{run.stdout}\n{run.stderr}")
    return time.perf_counter() - start, run.stdout


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--install", action="store_true", help="time a fresh venv and the README's pip lines too")
    args = parser.parse_args(argv)
    steps: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        python = sys.executable
        if args.install:
            steps["venv"], _ = timed([sys.executable, "-m", "venv", str(work / ".venv")], work)
            python = str(work / ".venv" / "bin" / "python")
            steps["pip install torch==2.13.0"], _ = timed([python, "-m", "pip", "install", "-q", "torch==2.13.0"], work)
            steps["pip install -e ."], _ = timed([python, "-m", "pip", "install", "-q", "-e", str(ROOT)], work)
        steps["python train.py --algo ppo"], _ = timed([python, str(ROOT / "train.py"), "--algo", "ppo",
                                                       "--no-progress-bar"], work)
        steps["python evaluate.py …"], output = timed(
            [python, str(ROOT / "evaluate.py"), "--agent", "passive", "--agent", "lqr", "--agent",
             "runs/latest/best_model.zip", "--no-progress-bar"], work)
        report = json.loads((work / "reports" / "LightSail-v0" / "report.json").read_text())
    ppo = next(summary for name, summary in report["agents"].items() if name.startswith("ppo"))
    result = {"date": time.strftime("%Y-%m-%d"), "machine": machine(),
              "versions": versions(), "seconds": {k: round(v, 1) for k, v in steps.items()},
              "train_and_evaluate_s": round(steps["python train.py --algo ppo"] + steps["python evaluate.py …"], 1),
              "ppo_success_rate": ppo["success_rate"], "ppo_median_pointing_rad": ppo["terminal_pointing_rad"]["median"],
              "episodes": ppo["episodes"]}
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    cli.write_whole(RESULTS, json.dumps(result, indent=2) + "\n")
    for step, seconds in result["seconds"].items():
        print(f"{seconds:7.1f} s  {step}")
    print(f"train + evaluate: {result['train_and_evaluate_s']} s; PPO success {ppo['success_rate']:.1%} on "
          f"{ppo['episodes']} episodes -> {RESULTS.relative_to(ROOT)}")
    print(output.strip().splitlines()[-1])
    return 0


if __name__ == "__main__":
    sys.exit(main())
