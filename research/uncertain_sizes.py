"""How large must LightSailUncertain-v1's unknowns be before the best classical design falls 10 points
below the ceiling? Its sizes (curvature, absorptivity, power, pointing bias) scaled together by k.

    python -m research.uncertain_sizes [--episodes 100] [--scales 1 1.5 2]   # research/results/uncertain_sizes.json

At each k the task is ``LightSailUncertain-v1`` with ``model_uncertainty`` the task's sizes times k
(``ModelUncertainty.scaled``; k = 1 is the task). On the same paired episodes play: LQG; the offset-free
adaptive bank ``lqg-mm-offset`` as shipped (its models at 0.85, 1 and 1.15 of the power and of the
curvature, ¾ of v1's half-widths); the same bank designed for the scaled sizes (``bank spanning the
sizes``: models at 1 and 1 ± ¾ of the scaled half-width, what a designer who read the task's sizes
would build; at k = 1 the shipped grid); and the ceiling ``lqg-oracle``. A scale beyond a size's limit
(absorptivity ≤ 1, curvature keeping R > a) is refused. Scales already measured on the same episodes
are kept, so a stopped run resumes with the next one.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np

import sail_env  # noqa: F401
from agents.adaptive import OffsetFreeMultipleModelLQGAgent
from agents.evaluation import DEFAULT_SEED, paired_difference, run_agent
from agents.lqg import LQGAgent
from agents.oracle import OracleLQGAgent
from agents.sb3 import one_thread_per_process
from sail_env.core.spec import EpisodeSpec
from sail_env.physics.rigid3d.uncertainty import TASK_UNCERTAINTY

ENV_ID = "LightSailUncertain-v1"
SCALES = (1.0, 1.5, 2.0)
#: The bank's outer models at this fraction of the drawn half-width (the shipped grid's rule at v1's).
GRID_REACH = 0.75
CEILING = "lqg-oracle"


def sizes(scale: float) -> dict[str, float]:
    """The task's sizes times ``scale``, as ``model_uncertainty``'s dict (``ValueError`` past a limit)."""
    scaled = TASK_UNCERTAINTY.scaled(scale)
    return {k: v for k, v in dataclasses.asdict(scaled).items() if k != "v0_draws"}


def agents(scale: float) -> dict[str, Callable[[EpisodeSpec], object]]:
    """The designs compared at ``scale``, by name."""
    reach = GRID_REACH * scale * TASK_UNCERTAINTY.power  # power and curvature share v1's half-width, 0.2
    return {"lqg": LQGAgent, "lqg-mm-offset": OffsetFreeMultipleModelLQGAgent,
            "bank spanning the sizes": lambda spec: OffsetFreeMultipleModelLQGAgent(
                spec, grid=(1.0 - reach, 1.0, 1.0 + reach)),
            CEILING: OracleLQGAgent}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED)
    parser.add_argument("--scales", type=float, nargs="+", default=list(SCALES))
    parser.add_argument("--out", type=Path, default=Path("research/results/uncertain_sizes.json"))
    args = parser.parse_args(argv)
    one_thread_per_process()
    results = json.loads(args.out.read_text()) if args.out.is_file() else {}
    for scale in args.scales:
        key, designs = f"x{scale:g}", agents(scale)
        done = results.get(key, {})
        if done.get("episodes") == args.episodes and done.get("seed") == args.seed and set(designs) <= set(
                done.get("agents", {})):
            continue
        try:
            kwargs = {"model_uncertainty": sizes(scale)}
            env = gym.make(ENV_ID, **kwargs)
        except ValueError as err:
            results[key] = {"refused": str(err)}
            args.out.write_text(json.dumps(results, indent=1))
            print(f"{key}: {err}", flush=True)
            continue
        entry = results[key] = {"sizes": kwargs["model_uncertainty"], "episodes": args.episodes, "seed": args.seed,
                                "agents": {}}
        outcomes = {}
        for name, make in designs.items():
            played = run_agent(ENV_ID, make(env.unwrapped.episode_spec), args.episodes, args.seed, progress=False,
                               env_kwargs=kwargs)
            outcomes[name] = np.array([e["success"] for e in played])
            entry["agents"][name] = {"success_rate": float(outcomes[name].mean()),
                                     "diverged": int(sum(e["diverged"] for e in played))}
            print(f"{key} {name}: {outcomes[name].mean():.1%}", flush=True)
        for name, row in entry["agents"].items():
            if name != CEILING:
                row["vs_ceiling"] = paired_difference(outcomes[name], outcomes[CEILING])
        args.out.write_text(json.dumps(results, indent=1, allow_nan=False))


if __name__ == "__main__":
    main()
