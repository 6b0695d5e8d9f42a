"""Where the designs and the learners fail on ``LightSailUncertain-v2``: the success of each, kept in
``benchmarks/results/uncertain.json`` for the README's 200 paired episodes, by the episode's draw.

    python -m research.uncertain_failures        # writes research/results/uncertain_failures.json

The draws are not stored with the outcomes; they are drawn again as the env draws them at reset (the
episode's generator's first ``plant.n_draws`` numbers made factors by ``plant.factors``), and each
is checked against the env's own: the axial acceleration of a reset with that seed must be the one the
factors give. The power reaching the sail is the beam power's factor times the transmission's (its
spread's and the uncertainty's, docs/physics.md §16). Each factor is cut into equal-count bins; a
learner's entry averages its seeds per episode. Then the top quarter of the power split at its median
beam offset, and each one's correlation of success with the power's distance from nominal: how much it
behaves as a fixed design tuned at the nominal sail.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding

import sail_env  # noqa: F401

ENV_ID = "LightSailUncertain-v2"
RESULTS = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "uncertain.json"
CLASSICAL = ("lqg", "lqg-mm", "lqg-mm-offset")
#: The learners: a label and the part of the run names (the results' keys) that picks its seeds.
LEARNERS = (("PPO, clipped likelihood", "history8-mean-mb32-clip-10M-seed"),
            ("PPO, clipped likelihood + tanh-mean", "history8-mean-mb32-clip-tanh-10M-seed"))


def episode_factors(env: gym.Env, seeds: range) -> tuple[tuple[str, ...], np.ndarray]:
    """The factors (len(seeds), F) each episode seed draws, and their names; ``ValueError`` if one is
    not the env's draw."""
    plant = env.unwrapped.episode_spec.plant
    factors = np.array([plant.factors(seeding.np_random(seed)[0].random((1, plant.n_draws)))[0] for seed in seeds])
    for seed, row in zip(seeds, factors):
        env.reset(seed=seed)
        drawn = env.unwrapped.state.params.acceleration[0]
        if not np.isclose(plant.params(row[None]).acceleration[0], drawn, rtol=1e-12, atol=0.0):
            raise ValueError(f"episode {seed}: its factors are not the env's draw")
    return plant.spread_fields, factors


def binned(success: np.ndarray, values: np.ndarray, bins: int) -> tuple[list[float], list[float]]:
    """The bins' edges (equal counts) and the mean success in each."""
    edges = np.quantile(values, np.linspace(0.0, 1.0, bins + 1))
    index = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, bins - 1)
    return edges.tolist(), [float(success[index == b].mean()) for b in range(bins)]


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bins", type=int, default=4)
    parser.add_argument("--out", type=Path, default=Path("research/results/uncertain_failures.json"))
    args = parser.parse_args(argv)
    task = json.loads(RESULTS.read_text())[ENV_ID]
    outcomes = {name: np.array(task["agents"][name]["success"], float) for name in CLASSICAL}
    for label, part in LEARNERS:
        runs = sorted(name for name in task["agents"] if part in name)
        outcomes[f"{label}: {len(runs)} run(s)"] = np.mean([task["agents"][name]["success"] for name in runs], axis=0)
    env = gym.make(ENV_ID)
    names, factors = episode_factors(env, range(task["seed"], task["seed"] + task["episodes"]))
    columns = {name: factors[:, i] for i, name in enumerate(names)}
    columns["power at the sail"] = columns["beam_power"] * columns["transmission"]
    columns["beam offset [cm]"] = np.hypot(columns["bias_x"] - 1.0, columns["bias_y"] - 1.0)  # × 1 cm
    result = {"env": ENV_ID, "episodes": task["episodes"], "seed": task["seed"], "bins": args.bins, "factors": {}}
    for factor in ("power at the sail", "beam offset [cm]", "curvature", "absorptivity", "mass", "inertia"):
        entry = result["factors"][factor] = {"success": {}}
        print(f"\n{factor}: bins of {task['episodes'] // args.bins} episodes")
        for name, success in outcomes.items():
            edges, rates = binned(success, columns[factor], args.bins)
            entry["edges"], entry["success"][name] = edges, rates
            print(f"  {name:46s} " + "  ".join(f"{rate:6.1%}" for rate in rates))
        print(f"  {'bin edges':46s} " + "  ".join(f"{edge:6.3f}" for edge in entry["edges"]))
    # In the top quarter of the power, the beam offset's share: that quarter split at its median offset.
    power, offset = columns["power at the sail"], columns["beam offset [cm]"]
    top = power >= np.quantile(power, 0.75)
    large = offset > np.median(offset[top])
    result["top_power_quarter_by_offset"] = {
        name: [float(success[top & ~large].mean()), float(success[top & large].mean())]
        for name, success in outcomes.items()}
    print("\nthe top quarter of the power, split at its median beam offset: small, large")
    for name, (small, big) in result["top_power_quarter_by_offset"].items():
        print(f"  {name:46s} {small:6.1%}  {big:6.1%}")
    # How much each depends on the power's distance from nominal: a fixed design tuned at the nominal sail
    # fails on both sides of it; one that adapts to the draw does not.
    distance = np.abs(columns["power at the sail"] - 1.0)
    result["correlation_with_power_off_nominal"] = {name: float(np.corrcoef(success, distance)[0, 1])
                                                   for name, success in outcomes.items()}
    print("\ncorrelation of success with |power at the sail - 1|")
    for name, value in result["correlation_with_power_off_nominal"].items():
        print(f"  {name:46s} {value:+.2f}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
