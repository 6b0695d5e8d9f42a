"""The best classical design for LightSailUncertain-v1 we could make: LQG's input weight and its filter's
model-mismatch floor chosen on selection episodes (seeds 0–99, apart from evaluate.py's 100000+).

    python -m research.uncertain_design [--episodes 100]    # writes research/results/uncertain_design.json

A larger input weight lowers the loop's bandwidth (a margin against the stiffer draws, whose fast mode
the light delay puts near the loop's phase limit); a larger mismatch floor makes the filter trust its
nominal model less (the "inflated process noise" robust design). Each cell is the success rate of
``LQGAgent(spec, input_weight, model_mismatch)`` on the same episodes.
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import gymnasium as gym
import numpy as np

import sail_env  # noqa: F401
from agents.evaluation import run_agent
from agents.lqg import LQGAgent
from agents.sb3 import one_thread_per_process

ENV_ID = "LightSailUncertain-v1"
INPUT_WEIGHTS = (1.0, 3.0, 10.0, 30.0)
MISMATCHES = (3e-3, 1e-2, 3e-2)
SELECTION_SEED = 0


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--out", type=Path, default=Path("research/results/uncertain_design.json"))
    args = parser.parse_args(argv)
    one_thread_per_process()
    spec = gym.make(ENV_ID).unwrapped.episode_spec
    results = {"env": ENV_ID, "episodes": args.episodes, "seed": SELECTION_SEED, "cells": []}
    for weight, mismatch in itertools.product(INPUT_WEIGHTS, MISMATCHES):
        try:
            agent = LQGAgent(spec, input_weight=weight, model_mismatch=mismatch)
        except ValueError as err:
            results["cells"].append({"input_weight": weight, "model_mismatch": mismatch, "error": str(err)})
            continue
        played = run_agent(ENV_ID, agent, args.episodes, SELECTION_SEED, progress=False)
        rate = float(np.mean([e["success"] for e in played]))
        results["cells"].append({"input_weight": weight, "model_mismatch": mismatch, "success_rate": rate,
                                 "diverged": int(sum(e["diverged"] for e in played))})
        args.out.write_text(json.dumps(results, indent=1))
        print(f"input weight {weight:g}, mismatch {mismatch:g}: {rate:.1%}", flush=True)


if __name__ == "__main__":
    main()
