"""How many draws the 3D realistic coast needs: the score with a draw after every 5 s piece (today)
against fewer draws from the same exact moments (issue 18's coast; docs/physics.md §14).

    python -m benchmarks.coast_draws [--task LightSail3DRealistic-v1] [--agents passive lqg]
                                     [--episodes 12] [--samples 2000] [--out PATH]

Today's coast draws the state from the Gaussian of each piece's exact moments after every piece (118
of ~5 s to cut-off). The push noise multiplies the state, so the end state is not Gaussian; the
draws keep its first two moments exact whatever their number, and what fewer draws change is only
the distribution's shape. A coast of a few long interaction steps (:mod:`benchmarks.coast_interaction`)
would draw after each step or once at the end. This measures what that does to the score.

For every coast to cut-off of ``--episodes`` episodes (seeds 100000, …) of each of ``--agents`` (their
recorded inputs), ``--samples`` end states with the plant's own propagators and draw
(:func:`~sail_env.physics.linear.sample_gaussian`): today's, with a draw after every 5 s piece; the
same with 1 s pieces (is today's distribution converged?); a draw after every tenth 5 s piece (12
draws); or once at the end; then the success probability (pointing ≤ 10 nrad at cut-off) and
the median pointing of each. Reported: each coast's numbers, and the mean over coasts of each way's
success probability with its paired difference to today's (its standard error over coasts; the
Monte Carlo error of one coast's probability is ≤ 1.1 points at 2,000 samples) and the median
pointing relative to today's, over all coasts and per agent.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import sail_env  # noqa: F401
from benchmarks.coast_modal import pieces_of, record_coasts
from sail_env.core.reward import succeeded
from sail_env.physics.linear import sample_gaussian
from sail_env.physics.noise import mean_and_covariance, second_moment
from sail_env.provenance import machine

RESULTS = Path(__file__).parent / "results"
#: The ways compared: (today's pieces split in, a draw after every n-th piece). Today's coast, its
#: pieces split in five (does today's distribution converge?), ~12 draws, one at the end.
WAYS = {"today": (1, 1), "1 s pieces": (5, 1), "every 10th piece": (1, 10), "once at the end": (1, 10**9)}


def end_states(plant, coast: dict, split: int, every: int, samples: int, rng: np.random.Generator) -> np.ndarray:
    """``samples`` end states of ``coast`` over today's pieces each split in ``split``, drawn after
    every ``every``-th piece and after the last."""
    count, length, _ = pieces_of(plant, coast)
    count, length = count * split, length / split
    middles = coast["start_s"][0] + (np.arange(count) + 0.5) * length
    propagators = plant._piece_propagators(coast["p"], coast["u"], middles[None], np.array([length]))
    zeros = np.zeros((samples, plant.n_states, plant.n_states))
    moment = second_moment(np.repeat(coast["x"], samples, axis=0), zeros)
    for j, propagator in enumerate(propagators):
        moment = (propagator @ moment[:, :, None])[:, :, 0]
        if (j + 1) % every == 0 or j == count - 1:
            mean, cov = mean_and_covariance(moment)
            state = sample_gaussian(mean, cov, rng.standard_normal(mean.shape))
            moment = second_moment(state, zeros)
    return state


def summarise(rows: list[dict]) -> dict:
    """Per way: the mean success probability over the coasts, its paired difference to today's with
    the standard error over coasts and the largest, and the median over coasts of the median
    pointing relative to today's."""
    today = np.array([r["today"]["success"] for r in rows])
    out = {}
    for name in WAYS:
        success = np.array([r[name]["success"] for r in rows])
        difference = success - today
        ratio = [r[name]["median_pointing_rad"] / r["today"]["median_pointing_rad"] for r in rows]
        out[name] = {"mean_success": float(success.mean()), "difference_to_today": float(difference.mean()),
                     "standard_error": float(difference.std(ddof=1) / np.sqrt(len(rows))),
                     "largest_difference": float(np.abs(difference).max()), "median_pointing_ratio": float(np.median(ratio))}
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="LightSail3DRealistic-v1")
    parser.add_argument("--agents", nargs="+", default=["passive", "lqg"])
    parser.add_argument("--episodes", type=int, default=12)
    parser.add_argument("--samples", type=int, default=2000)
    parser.add_argument("--out", type=Path, default=RESULTS / "coast_draws.json")
    args = parser.parse_args(argv)

    plant, coasts = record_coasts(args.task, args.agents, args.episodes)
    coasts = [c for c in coasts if float(c["duration"][0]) > 100.0]  # to cut-off, not a reset's pre-control coast
    rng = np.random.default_rng(0)
    rows = []
    for coast in coasts:
        end_s = coast["start_s"] + coast["duration"]
        row = {"agent": coast["agent"], "pieces": pieces_of(plant, coast)[0]}
        for name, (split, every) in WAYS.items():
            state = end_states(plant, coast, split, every, args.samples, rng)
            pointing = plant.pointing(coast["p"].repeat(args.samples), state, np.repeat(end_s, args.samples))
            row[name] = {"success": float(np.mean(succeeded(pointing))), "median_pointing_rad": float(np.median(pointing))}
        rows.append(row)
        print(f"{row['agent']:8s} " + "; ".join(f"{name} {row[name]['success']:.3f} ({row[name]['median_pointing_rad']:.2e} rad)"
                                          for name in WAYS), flush=True)

    summary = {group: summarise([r for r in rows if group in ("all", r["agent"])]) for group in ("all", *args.agents)}
    for group, ways in summary.items():
        for name, numbers in ways.items():
            print(f"{group:8s} {name}: success {numbers['mean_success']:.4f}, minus today's "
                  f"{numbers['difference_to_today']:+.4f} ± {numbers['standard_error']:.4f} "
                  f"(largest {numbers['largest_difference']:.3f}); median pointing {numbers['median_pointing_ratio']:.3f} × today's")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"task": args.task, "agents": args.agents, "episodes": args.episodes,
                                    "samples": args.samples, "machine": machine(), "coasts": len(rows),
                                    "summary": summary, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
