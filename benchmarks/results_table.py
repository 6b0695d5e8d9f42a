"""The README's results table, rendered from the kept results: one row per task, every number read
from a file in ``benchmarks/results/`` (no storage, no runs, no training: a few seconds).

    python -m benchmarks.results_table                      # print the table
    python -m benchmarks.results_table --readme README.md   # also put it between README's results-table markers

Each task's row comes from one set of 200 paired episodes (seeds 100000–100199, evaluate.py's default):
the kept benchmark grids (``agents.grid export``: :data:`GRIDS`) and, for the uncertain-model tasks,
whose learners were evaluated by ``benchmarks.ceiling``, its results (:data:`UNCERTAIN`). A grid cell
played again (``agents.grid redo``) counts by its latest trial, as in ``agents.grid render``. Learners
are the grids' ``tuned`` cells (the shipped YAML; seeds 0–2), the runs :data:`UNCERTAIN_LEARNERS`
names, and those :data:`BESIDE_GRIDS` names beside a grid's (evaluated by ``benchmarks.ceiling`` on the
grid's episodes: its LQG must play them as the grid's did); success is the mean ± the standard deviation over seeds (``np.std``, as the grid's tables);
the paired difference to the best classical design averages a learner's seeds per episode, with a
95 % bootstrap interval (``agents.evaluation.paired_difference``). The full tables these rows come
from: docs/learners.md and docs/tasks.md.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents import cli
from agents.evaluation import paired_difference

ROOT = Path(__file__).resolve().parents[1]
#: The kept grids (``agents.grid export``), each a study of that name.
GRIDS = {name: ROOT / "benchmarks" / "results" / "grid" / f"{name}.json" for name in ("easy", "3d", "realistic")}
#: ``benchmarks.ceiling``'s results on the uncertain-model task (its learners are train.py runs).
UNCERTAIN = ROOT / "benchmarks" / "results" / "uncertain.json"
#: The uncertain-model tasks in :data:`UNCERTAIN`: the current version, and v1, on which its learners were trained.
UNCERTAIN_TASKS = ("LightSailUncertain-v2", "LightSailUncertain-v1")
#: The table's rows, in order.
TASKS = ("LightSail-v0", "LightSailDeepDish-v0", "LightSail3D-v0", "LightSailRealistic-v0",
         "LightSail3DRealistic-v1", *UNCERTAIN_TASKS)
#: The classical designs a learner is compared with (the best of them on the task).
DESIGNS = ("lqr", "lqg", "lqg-mm", "lqg-mm-offset")
#: The bounds that read the simulator's truth (``agents/oracle.py``).
BOUNDS = ("lqr-oracle", "lqg-oracle")
#: How the table names the grids' agents.
NAMES = {"passive": "passive", "lqr": "LQR", "lqg": "LQG", "lqg-mm": "`lqg-mm`", "lqg-mm-offset": "`lqg-mm-offset`",
         "ppo": "PPO", "sac": "SAC", "td3": "TD3", "recurrent_ppo": "RecurrentPPO"}
#: The uncertain tasks' learners in :data:`UNCERTAIN`, per task: a label, whether it corrects a
#: classical design (a residual), and its runs (one per seed).
UNCERTAIN_LEARNERS = {"LightSailUncertain-v2": (
    ("JAX PPO, 8-observation history and the episode's mean, the clipped likelihood, the mean squashed into the "
     "box, less exploration noise with a σ per state, a GRU of 128 units, γ 0.999 and λ 0.99 (10M steps, CPU; "
     "each curve's best)", False,
     tuple(f"runs/jax/uncertain-v2-history8-mean-mb32-clip-tanh-logstd2-sdstd-gru128-g999-l99-10M-seed{seed}/best_policy.npz"
           for seed in range(5))),
    ("JAX PPO, 8-observation history and the episode's mean, the clipped likelihood, the mean squashed into the "
     "box (10M steps, CPU; each curve's best)", False,
     tuple(f"runs/jax/uncertain-v2-history8-mean-mb32-clip-tanh-10M-seed{seed}/best_policy.npz" for seed in range(5))),
    ("JAX PPO, the same with a critic that sees the draw in training (`--privileged-critic`)", False,
     tuple(f"runs/jax/uncertain-v2-history8-mean-mb32-clip-tanh-privcritic-10M-seed{seed}/best_policy.npz"
           for seed in (1, 2))),
    ("JAX PPO, the same without the squashed mean", False,
     tuple(f"runs/jax/uncertain-v2-history8-mean-mb32-clip-10M-seed{seed}/best_policy.npz" for seed in range(5))),
    ("JAX PPO, the same without the clipped likelihood", False,
     ("runs/jax/uncertain-v2-history8-mean-mb32-10M-seed0/best_policy.npz",)),
    ("JAX PPO, 8-observation history and the episode's mean (lr 3e-4, 8 minibatches)", False,
     ("runs/jax/uncertain-v2-history8-mean-10M-seed0/best_policy.npz",)),
    ("JAX PPO, GRU, learning rate floored (10M steps)", False,
     ("runs/jax/uncertain-v2-gru128-floor-10M-seed0/best_policy.npz",)),
    ("JAX PPO, 8-observation history (10M steps, CPU; its curve's best)", False,
     ("runs/jax/uncertain-v2-history8-10M-seed0/best_policy.npz",)),
    ("JAX PPO, 8-observation history (4M steps)", False, ("runs/jax/uncertain-v2-history8-seed0/policy.npz",)),
    ("JAX PPO, GRU (4M steps)", False, ("runs/jax/uncertain-v2-gru128-seed0/policy.npz",)),
), "LightSailUncertain-v1": (
    ("PPO residual on `lqg-mm-offset`", True,
     tuple(f"runs/tuned/ppo-residual-offset-v1-seed{seed}/best_model.zip" for seed in range(3))),
    ("PPO residual on `lqg-mm`", True, ("runs/tuned/ppo-residual-uncertain-seed0/best_model.zip",)),
    ("RecurrentPPO (untuned)", False, ("runs/tuned/rppo-uncertain-v1-seed0/best_model.zip",)),
    ("PPO (the study's trial)", False, ("runs/tuning/tune-ppo-LightSailUncertain-v1/trial-1/best_model.zip",)),
    ("PPO (v1's settings)", False, ("runs/tuned/ppo-uncertain-v1-from-v1-seed0/best_model.zip",)),
)}
#: Learners of a grid's task evaluated apart (the JAX backend's), per task: ``benchmarks.ceiling``'s
#: results file and the learners as in :data:`UNCERTAIN_LEARNERS`.
BESIDE_GRIDS = {"LightSail3DRealistic-v1": (ROOT / "benchmarks" / "results" / "learners_3d_realistic_v1.json", (
    ("JAX PPO, 8-observation history and the episode's mean (10M steps, CPU; its curve's best)", False,
     ("runs/jax/3d-realistic-v1-history8-mean-mb32-10M-seed0/best_policy.npz",)),
    ("JAX PPO, the same settings over 4M steps", False,
     tuple(f"runs/jax/3d-realistic-v1-mean-mb32-4M-seed{seed}/best_policy.npz" for seed in range(5))),
    ("JAX PPO, the same over 4M steps with the mean squashed into the box (`--tanh-mean`)", False,
     tuple(f"runs/jax/3d-realistic-v1-mean-mb32-tanh-4M-seed{seed}/best_policy.npz" for seed in range(5))),
    ("JAX PPO, the same with less exploration noise (`--tanh-mean --log-std-init -2`, 4M steps)", False,
     tuple(f"runs/jax/3d-realistic-v1-mean-mb32-tanh-logstd2-4M-seed{seed}/best_policy.npz" for seed in range(5))),
    ("JAX PPO, the same over 10M steps", False,
     tuple(f"runs/jax/3d-realistic-v1-mean-mb32-tanh-logstd2-10M-seed{seed}/best_policy.npz" for seed in range(5))),
    ("JAX PPO, the same over 4M steps with the clipped likelihood", False,
     tuple(f"runs/jax/3d-realistic-v1-mean-mb32-clip-4M-seed{seed}/best_policy.npz" for seed in range(5))),
    ("JAX PPO, 8-observation history and the episode's mean, the mean squashed into the box, less exploration "
     "noise, γ 0.999 and λ 0.99 (4M steps, CPU; each curve's best)", False,
     tuple(f"runs/jax/3d-realistic-v1-mean-mb32-tanh-logstd2-g999-l99-4M-seed{seed}/best_policy.npz" for seed in range(5))),
))}
SECTION = "results-table"
HEADER = ("| task | passive | LQR | LQG | best classical design | best learner (seeds) | "
          "learner vs that design (paired, 95 % CI) | ceiling (a bound) |\n"
          "|---|---:|---:|---:|---:|---:|---:|---:|")


@dataclass(frozen=True)
class Learner:
    """A learner's outcomes on a task's episodes, (seeds, episodes) booleans."""

    label: str
    residual: bool
    successes: np.ndarray

    @property
    def rate(self) -> float:
        return float(self.successes.mean())


@dataclass(frozen=True)
class Task:
    """What one row is made of: the classical agents' and bounds' outcomes (episodes,), the learners,
    and the learner cells the kept grid still has queued."""

    classical: dict[str, np.ndarray]
    learners: list[Learner]
    queued: int
    source: str


def grid_tasks(path: Path) -> dict[str, Task]:
    """Each task of a kept grid: its finished cells' outcomes (a cell run again: its latest trial)."""
    kept = json.loads(path.read_text())
    settings = kept["user_attrs"]["settings"]
    latest = {t["user_attrs"]["cell"]: t for t in kept["trials"] if t["state"] == "COMPLETE"}
    tasks = {}
    for env in settings["envs"]:
        cells = [t for t in latest.values() if t["params"]["env"] == env]
        classical = {t["params"]["agent"]: np.array(t["user_attrs"]["summary"]["successes"], bool)
                     for t in cells if t["params"]["hyperparameters"] == "none"}
        learners = []
        for algo in settings["algos"]:
            seeds = sorted((t for t in cells if t["params"]["agent"] == algo and t["params"]["hyperparameters"] == "tuned"),
                           key=lambda t: t["params"]["seed"])
            if seeds:
                learners.append(Learner(NAMES[algo], False,
                                        np.array([t["user_attrs"]["summary"]["successes"] for t in seeds], bool)))
        expected = len(settings["algos"]) * len(settings["tuned_seeds"])
        tasks[env] = Task(classical, learners, expected - sum(len(learner.successes) for learner in learners),
                          str(path.relative_to(ROOT)))
    return tasks


def uncertain_task(path: Path, env: str) -> Task:
    """An uncertain task from ``benchmarks.ceiling``'s results: the classical agents and bounds by
    name, the learners of :data:`UNCERTAIN_LEARNERS` by their runs."""
    agents = json.loads(path.read_text())[env]["agents"]
    classical = {name: np.array(row["success"], bool) for name, row in agents.items() if not name.endswith((".zip", ".npz"))}
    return Task(classical, kept_learners(agents, UNCERTAIN_LEARNERS[env]), 0, str(path.relative_to(ROOT)))


def kept_learners(agents: dict[str, Any], learners: tuple) -> list[Learner]:
    """The ``learners`` (label, residual, runs) among ``benchmarks.ceiling``'s rows ``agents``."""
    return [Learner(label, residual, np.array([agents[run]["success"] for run in runs], bool))
            for label, residual, runs in learners]


def beside_grid(task: Task, env: str, path: Path, learners: tuple) -> Task:
    """A grid's ``task`` with the ``learners`` evaluated apart in ``path`` (ValueError if that file's LQG
    did not play the grid's episodes as the grid did)."""
    agents = json.loads(path.read_text())[env]["agents"]
    if not np.array_equal(np.array(agents["lqg"]["success"], bool), task.classical["lqg"]):
        raise ValueError(f"{path.relative_to(ROOT)}: its LQG's episodes are not the grid's of {env}")
    return dataclasses.replace(task, learners=[*task.learners, *kept_learners(agents, learners)])


def kept_tasks() -> dict[str, Task]:
    """Every task of the table, from the kept files."""
    tasks: dict[str, Task] = {}
    for path in GRIDS.values():
        tasks.update(grid_tasks(path))
    for env in UNCERTAIN_TASKS:
        tasks[env] = uncertain_task(UNCERTAIN, env)
    for env, (path, learners) in BESIDE_GRIDS.items():
        tasks[env] = beside_grid(tasks[env], env, path, learners)
    return tasks


def percent(rate: float) -> str:
    return f"{100 * rate:.1f} %"


def learner_text(learner: Learner) -> str:
    """Mean ± std over seeds (the std only for several), and the number of seeds."""
    rates = learner.successes.mean(axis=1)
    spread = f" ± {100 * rates.std():.1f}" if len(rates) > 1 else ""
    return f"{learner.label} {percent(rates.mean())}{spread} ({len(rates)} seed{'s' * (len(rates) > 1)})"


def row(env: str, task: Task) -> tuple[str, str | None]:
    """The table row of one task, and the note it needs below the table (a residual's best
    learner acting alone) if any."""
    rates = {name: float(outcomes.mean()) for name, outcomes in task.classical.items()}
    design = max((name for name in DESIGNS if name in rates), key=lambda name: rates[name])  # first of equals
    bounds = [rates[name] for name in BOUNDS if name in rates]
    ceiling = percent(max(bounds)) if bounds else f"{percent(rates['lqr'])} (LQR)‡"
    learner, versus, note = "queued¹" if task.queued else "–", "–", None
    if not task.learners and not task.queued:
        note = f"`{env}`: no learner has been evaluated on it yet."
    if task.learners:
        best = max(task.learners, key=lambda learner: learner.rate)
        d = paired_difference(best.successes, task.classical[design])
        learner = learner_text(best)
        versus = f"{100 * d['difference']:+.1f} pts ({100 * d['ci95'][0]:+.1f} … {100 * d['ci95'][1]:+.1f})"
        alone = [other for other in task.learners if not other.residual]
        if best.residual and alone:
            note = (f"`{env}`, the best learner acting alone: "
                    f"{learner_text(max(alone, key=lambda other: other.rate))}.")
    cells = [f"`{env}`", *(percent(rates[name]) for name in ("passive", "lqr", "lqg")),
             f"{NAMES[design]} {percent(rates[design])}", learner, versus, ceiling]
    return "| " + " | ".join(cells) + " |", note


def render(tasks: dict[str, Task] | None = None) -> str:
    """The table and the notes below it, as markdown."""
    tasks = kept_tasks() if tasks is None else tasks
    lines, row_notes, notes = [HEADER], [], []
    for env in TASKS:
        line, note = row(env, tasks[env])
        lines.append(line)
        row_notes += [note] if note else []
    queued = [env for env in TASKS if tasks[env].queued]
    if queued:
        sources = sorted({tasks[env].source for env in queued})
        notes.append(f"¹ {', '.join(f'`{env}`' for env in queued)}: the learners' cells are queued in the kept grid "
                     f"({', '.join(f'`{source}`' for source in sources)}), not yet run.")
    own_bound = [env for env in TASKS if not any(name in tasks[env].classical for name in BOUNDS)]
    if own_bound:
        notes.append(f"‡ {', '.join(f'`{env}`' for env in own_bound)}: nothing is hidden from the LQR (no delay, "
                     "noise or parameter spread), it is its own bound.")
    notes += row_notes
    return "\n".join([*lines, "", *(f"- {note}" for note in notes)]) if notes else "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = cli.Parser(prog="python -m benchmarks.results_table", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter)
    parser.add_argument("--readme", type=Path, help=f"also write the table between this file's {SECTION} markers")
    try:
        args = parser.parse_args(argv)
        if args.readme is not None:
            cli.readme_around_section(args.readme, SECTION)
        table = render()
    except (cli.UsageError, OSError, KeyError, ValueError) as err:
        return cli.fail(err)
    if args.readme is not None:
        cli.replace_readme_section(args.readme, SECTION, table)
    print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
