"""Does ``train.py --resume`` after a kill mid-way give as good a model as an uninterrupted run?

    python -m research.resume_quality [--algo ppo] [--env LightSail-v0] [--episodes 200]

Trains the shipped configuration twice with the same seed: once straight through, once
interrupted with SIGINT (Ctrl-C) as soon as the checkpoint at half the budget is written,
then continued with ``--resume``. Both final and best models then play the same seeded
episodes (evaluate.py's pairing). Finished runs under ``--out`` are reused.
"""

from __future__ import annotations

import argparse
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
from agents import evaluation as evaluate
from agents.sb3 import load_hyperparams
from agents.training import CHECKPOINT_PREFIX, checkpoint_steps

TRAIN = [sys.executable, str(ROOT / "train.py"), "--no-progress-bar"]


def uninterrupted(algo: str, env_id: str, out: Path) -> Path:
    run_dir = out / "uninterrupted"
    if not (run_dir / "final_model.zip").is_file():
        subprocess.run([*TRAIN, "--algo", algo, "--env", env_id, "--out", str(run_dir)], check=True)
    return run_dir


def interrupted_then_resumed(algo: str, env_id: str, out: Path, save_freq: int, halfway: int) -> Path:
    """Ctrl-C once the first checkpoint at or past ``halfway`` steps exists, then ``--resume``."""
    run_dir = out / "resumed"
    if (run_dir / "final_model.zip").is_file():
        return run_dir
    if not (run_dir / "run.json").is_file():  # else this script was itself stopped: just resume
        proc = subprocess.Popen([*TRAIN, "--algo", algo, "--env", env_id, "--out", str(run_dir),
                                 "--save-freq", str(save_freq)])
        while proc.poll() is None:
            steps = [checkpoint_steps(p) for p in run_dir.glob(f"checkpoints/{CHECKPOINT_PREFIX}_*_steps.zip")]
            if steps and max(steps) >= halfway:
                proc.send_signal(signal.SIGINT)
                break
            time.sleep(0.5)
        if proc.wait() != 130:
            raise RuntimeError(f"the run was not interrupted mid-way (exit {proc.returncode})")
    subprocess.run([*TRAIN, "--resume", str(run_dir)], check=True)
    return run_dir


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", default="ppo")
    parser.add_argument("--env", default="LightSail-v0")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--seed", type=int, default=evaluate.DEFAULT_SEED, help="first evaluation episode seed")
    parser.add_argument("--out", type=Path, default=Path("runs/resume_quality"))
    args = parser.parse_args(argv)

    total = int(load_hyperparams(args.algo, args.env)["n_timesteps"])
    save_freq = max(total // 10, 1)
    runs = {"uninterrupted": uninterrupted(args.algo, args.env, args.out),
            "resumed": interrupted_then_resumed(args.algo, args.env, args.out, save_freq, total // 2)}
    sessions = json.loads((runs["resumed"] / "run.json").read_text())["sessions"]
    print(f"resumed run: interrupted at {sessions[0]['timesteps']} of {total} steps, "
          f"{len(sessions)} sessions")
    specs = [str(d / f"{kind}.zip") for d in runs.values() for kind in ("final_model", "best_model")]
    results, _ = evaluate.evaluate(args.env, specs, args.episodes, args.seed)
    print(f"\n{args.algo} on {args.env}, {args.episodes} paired episodes (seeds from {args.seed})\n")
    print("| run | model | success rate | median pointing [rad] |")
    print("|---|---|---:|---:|")
    for (name, episodes), spec in zip(results.items(), specs):
        summary = evaluate.summarise(episodes)
        run, model = Path(spec).parent.name, Path(spec).stem
        print(f"| {run} | {model} | {summary['success_rate']:.1%} | "
              f"{evaluate.fmt(summary['terminal_pointing_rad']['median'])} |")


if __name__ == "__main__":
    main()
