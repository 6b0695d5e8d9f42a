"""Learning curves of train.py runs: selection success against env steps, over seeds.

    python -m benchmarks.learning_curves --env LightSailRealistic-v0 \\
        --runs "PPO tuned=runs/tuned/ppo-realistic-v0-seed*" \\
        --runs "PPO tuned, frame_stack 4=runs/tuned/ppo-realistic-v0-fs4-seed*" \\
        --report benchmarks/results/learners_realistic_v0.json --out docs/images/learning-curve-realistic-v0.png

Each ``--runs LABEL=GLOB`` is one configuration: the runs its glob matches are its seeds. A run's
``evaluations.npz`` (SB3's EvalCallback log, written by train.py) holds the success of every
selection episode at every evaluation; the curve is the mean over seeds of each evaluation's
success rate, the band its range over seeds. Evaluations are compared at the steps every seed
reached, up to the first where their steps differ (a resumed run evaluates at shifted steps).

With ``--grid FILE`` (a grid export, ``python -m agents.grid export``) the curves come from the grid's
cells instead, whose trials keep every evaluation's success rate as Optuna intermediate values, so
the figure can be drawn again in a checkout without the runs; each glob then matches cell names:

    python -m benchmarks.learning_curves --env LightSailRealistic-v0 --grid benchmarks/results/grid/realistic.json \\
        --runs "SAC tuned=LightSailRealistic-v0-sac-tuned-*" --out sac.png

With ``--report`` (an ``evaluate.py`` report.json, or ``benchmarks.ceiling``'s JSON) the
classical agents' success rates on the report's episodes are drawn as horizontal lines (LQG and the
ceiling: ``lqr-oracle``, ``lqg-oracle``; the adaptive ``lqg-mm`` and ``lqg-mm-offset`` where they were played), labelled with their episode count: the selection episodes
are other episodes, so the lines are a reference level, not a paired comparison.
"""

from __future__ import annotations

import fnmatch
import glob
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from agents import cli, training  # noqa: E402

#: The report's agents drawn as reference lines, and their labels.
REFERENCES = {"lqg": "LQG", "lqg-mm": "adaptive LQG (lqg-mm)", "lqg-mm-offset": "adaptive, offset-free (lqg-mm-offset)",
              "lqr-oracle": "ceiling: LQR oracle", "lqg-oracle": "ceiling: LQG oracle"}
#: Their line styles, one each (a sixth reference needs a sixth style).
REFERENCE_STYLES = ("--", ":", (0, (1, 4)), "-.", (0, (5, 1, 1, 1, 1, 1)))
#: The y axis's top [%]: above 100, so that a line at 98-100 % (the bounds, the adaptive LQG) is not
#: drawn into the frame, with room above it for its label.
Y_TOP = 106.0
#: Reference lines closer than this [points of success] cannot be told apart at the figure's size:
#: they are named together above the highest of them.
BUNDLE_POINTS = 2.0


def run_histories(pattern: str) -> dict[str, list[tuple[int, float]]]:
    """The learning curve of each train.py run that ``pattern`` matches, by run folder."""
    histories = {run: training.selection_history(Path(run)) for run in sorted(glob.glob(pattern))}
    return {run: history for run, history in histories.items() if history}


def cell_histories(grid_file: Path, pattern: str) -> dict[str, list[tuple[int, float]]]:
    """The learning curve of each cell of a grid export (``agents.grid export``) whose name
    ``pattern`` matches: its trial's intermediate values (a cell run again: its latest trial)."""
    trials = json.loads(grid_file.read_text())["trials"]
    latest = {trial["user_attrs"].get("cell", ""): trial for trial in trials}
    return {cell: sorted((int(step), rate) for step, rate in trial["intermediate_values"].items())
            for cell, trial in sorted(latest.items())
            if fnmatch.fnmatchcase(cell, pattern) and trial["intermediate_values"]}


def curves(histories: dict[str, list[tuple[int, float]]], pattern: str) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The evaluation steps every run reached, the success rates (seeds, steps), the runs."""
    if not histories:
        raise cli.UsageError(f"--runs {pattern!r}: no run with a learning curve (an evaluations.npz with "
                             "successes, or a grid cell with intermediate values)")
    logs = [np.array(history).T for history in histories.values()]  # each: steps row, rates row
    common = min(log.shape[1] for log in logs)
    steps = logs[0][0, :common]
    for log in logs:  # a resumed run evaluates at shifted steps after its resume: stop there
        same = log[0, :common] == steps
        common = common if same.all() else int(np.argmin(same))
        steps = steps[:common]
    if not common:
        raise cli.UsageError(f"--runs {pattern!r}: the runs share no evaluation step")
    return steps.astype(int), np.stack([log[1, :common] for log in logs]), list(histories)


def reference_rates(report: Path, env_id: str) -> dict[str, tuple[float, int]]:
    """Success rate and episode count of each reference agent in an evaluate.py report.json or in
    ``benchmarks.ceiling``'s results (the entry of ``env_id``)."""
    record = json.loads(report.read_text())
    agents = record["agents"] if "agents" in record else record[env_id]["agents"]
    return {label: (agents[name]["success_rate"], agents[name]["episodes"])
            for name, label in REFERENCES.items() if name in agents}


def bundles(references: dict[str, tuple[float, int]]) -> list[list[str]]:
    """Groups of two or more reference lines (by label) that lie within :data:`BUNDLE_POINTS` of
    their neighbour, lowest first."""
    groups: list[list[str]] = []
    previous = None
    for label, (rate, _) in sorted(references.items(), key=lambda item: item[1][0]):
        if previous is not None and 100 * (rate - previous) < BUNDLE_POINTS:
            groups[-1].append(label)
        else:
            groups.append([label])
        previous = rate
    return [group for group in groups if len(group) > 1]


def main(argv: list[str] | None = None) -> int:
    parser = cli.Parser(prog="python -m benchmarks.learning_curves", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter)
    parser.add_argument("--env", required=True, help="the task the runs trained on (the plot's title)")
    parser.add_argument("--runs", action="append", required=True, metavar="LABEL=GLOB",
                        help="a configuration's runs, one per seed; repeat to compare (with --grid: "
                             "a glob of the grid's cell names)")
    parser.add_argument("--grid", type=Path, metavar="FILE",
                        help="read the curves from a grid export (agents.grid export) instead of run folders")
    parser.add_argument("--report", type=Path,
                        help="an evaluate.py report.json or benchmarks.ceiling's JSON, for the reference lines")
    parser.add_argument("--out", type=Path, required=True, help="the PNG to write")
    parser.add_argument("--legend", choices=("inside", "below"), default="inside",
                        help="the legend in the axes' lower right corner, or below them")
    parser.add_argument("--log-steps", action="store_true",
                        help="env steps on a logarithmic axis (runs whose lengths differ by decades)")
    try:
        args = parser.parse_args(argv)
        configs = []
        for item in args.runs:
            label, sep, pattern = item.partition("=")
            if not sep or not label or not pattern:
                raise cli.UsageError(f"--runs {item!r}: expected LABEL=GLOB")
            histories = cell_histories(args.grid, pattern) if args.grid is not None else run_histories(pattern)
            configs.append((label, *curves(histories, pattern)))
        references = reference_rates(args.report, args.env) if args.report is not None else {}
        cli.check_writable_dir(args.out.parent, "--out")
    except (cli.UsageError, OSError, KeyError, json.JSONDecodeError) as err:
        return cli.fail(err)

    fig, ax = plt.subplots(figsize=(7.5, 4.2 if args.legend == "inside" else 5.4))
    for label, steps, rates, runs in configs:
        line, = ax.plot(steps, 100 * rates.mean(axis=0), label=f"{label} (mean of {len(runs)} seeds, range shaded)")
        ax.fill_between(steps, 100 * rates.min(axis=0), 100 * rates.max(axis=0), color=line.get_color(), alpha=0.2)
    for (label, (rate, episodes)), style in zip(references.items(), REFERENCE_STYLES):
        ax.axhline(100 * rate, color="k", linestyle=style, linewidth=1, label=f"{label}: {rate:.1%} ({episodes} episodes)")
    ax.set_xlabel("env steps")
    if args.log_steps:
        ax.set_xscale("log")
    ax.set_ylabel("selection success [%]")
    ax.set_title(f"{args.env}: success of the deterministic policy on the selection episodes")
    ax.set_ylim(0, Y_TOP)
    for group in bundles(references):
        rates = [100 * references[label][0] for label in group]
        ax.annotate(f"{' / '.join(group)}: {min(rates):.1f}–{max(rates):.1f} %, on top of each other",
                    (0.99, max(rates)), xycoords=("axes fraction", "data"), xytext=(0, 2), textcoords="offset points",
                    ha="right", va="bottom", fontsize=7, color="0.2")
    ax.grid(alpha=0.3)
    # Laid out before the legend: one below the axes would otherwise squeeze them (savefig's bbox takes it in).
    fig.tight_layout()
    if args.legend == "below":  # curves that fill the axes: the legend under them
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=2)
    else:
        ax.legend(fontsize=8, loc="lower right")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110, bbox_inches="tight")  # a legend below the axes is not cut off
    for label, steps, rates, runs in configs:
        last = rates[:, -1]
        print(f"{label}: {len(runs)} seeds to {steps[-1]:,} steps; last evaluation {100 * last.mean():.1f} % "
              f"(seeds {', '.join(f'{100 * r:.0f}' for r in last)}); best of each seed "
              f"{', '.join(f'{100 * r:.0f}' for r in rates.max(axis=1))} %")
    print(f"-> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
