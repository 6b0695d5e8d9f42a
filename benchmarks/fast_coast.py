"""The fast coast against the default coast, in law: each agent's success over fresh first episodes of each,
and the score's expectation against its samples.

    python -m benchmarks.fast_coast --env LightSailUncertain-v2 --agent passive --agent lqg --episodes 10000

``coast="fast"`` (:mod:`sail_env.jax.fast_coast`) plays the default coast's model on another grid of piece
ends, so its episodes are the default's in law, not draw for draw: the same agent's success rate over
``--episodes`` first episodes of each must agree within sampling error. The fast coast plays its own, smaller
bank of draws (:data:`~sail_env.jax.fast_coast.FAST_DRAWS`, ``--draws``); the default coast plays the same bank
here, so that the coasts alone differ. On the fast coast every episode also reports ``expected_success`` over ``--paths`` further coasts
from its window's end, whose mean must agree with the sampled success (the tower rule) and whose spread is
smaller. Each row goes into ``--out`` as it comes (``benchmarks/results/fast_coast.json``).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import sail_env.jax
from agents import cli
from agents.jax_policies import POLICIES
from benchmarks.jax_samplers import first_episodes, keep_row

RESULTS = Path(__file__).parent / "results" / "fast_coast.json"


def difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """The difference of two independent samples' means and its standard error."""
    return float(a.mean() - b.mean()), math.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))


def main(argv: list[str] | None = None) -> int:
    parser = cli.Parser(prog="python -m benchmarks.fast_coast", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter)
    parser.add_argument("--env", required=True, help="a task whose coast follows the flight")
    parser.add_argument("--agent", action="append", choices=sorted(POLICIES), required=True)
    parser.add_argument("--episodes", type=cli.positive_int, default=10000)
    parser.add_argument("--paths", type=cli.positive_int, default=16, help="the score's further coasts an episode")
    parser.add_argument("--draws", type=cli.positive_int, help="the fast coast's bank (default: its own)")
    parser.add_argument("--out", type=Path, default=RESULTS, help="add each row to this JSON file")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    try:
        fast_env, fast_params = sail_env.jax.make(args.env, coast="fast", draws=args.draws, expected_paths=args.paths)
    except ValueError as err:
        return cli.fail(cli.UsageError(f"--env {args.env}: {err}"))
    build = time.perf_counter() - start
    # The default coast on the same bank (the first draws of its own: the bank's generator is seeded): the coasts
    # alone differ. A bank of 512 draws scores a policy whose success varies across draws up to ~2 points apart
    # from the 4,096's.
    default_env, default_params = sail_env.jax.make(args.env, draws=int(fast_params.acceleration.shape[0]))
    for agent in args.agent:
        begin = time.perf_counter()
        default = first_episodes(default_env, default_params, agent, args.episodes)["is_success"].astype(float)
        middle = time.perf_counter()
        fast = first_episodes(fast_env, fast_params, agent, args.episodes)
        end = time.perf_counter()
        sampled, expected = fast["is_success"].astype(float), fast["expected_success"]
        coasts, coasts_error = difference(sampled, default)
        tower, tower_error = difference(expected, sampled)  # paired, so this error overstates: conservative
        row = {"env": args.env, "agent": agent, "episodes": args.episodes, "paths": args.paths,
               "fast_draws": int(fast_params.acceleration.shape[0]), "default": float(default.mean()),
               "fast": float(sampled.mean()), "fast_minus_default_in_standard_errors": coasts / coasts_error,
               "expected_success": float(expected.mean()),
               "expected_minus_sampled_in_standard_errors": tower / max(tower_error, 1e-12),
               "std_sampled": float(sampled.std()), "std_expected": float(expected.std()),
               "default_seconds": round(middle - begin, 1), "fast_seconds": round(end - middle, 1),
               "fast_build_seconds": round(build, 1), "date": time.strftime("%Y-%m-%d")}
        print(json.dumps(row), flush=True)
        keep_row(args.out, row)
    return 0


if __name__ == "__main__":
    sys.exit(main())
