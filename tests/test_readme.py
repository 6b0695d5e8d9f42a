"""The README's quick example runs and prints what the README says it prints; its results table is
the kept results rendered, as the docs' grid tables are their kept exports; it names every
registered id once; the paths and ``python -m`` modules that the README and the docs cite exist."""

from __future__ import annotations

import dataclasses
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from agents import cli
from benchmarks import results_table

ROOT = Path(__file__).resolve().parents[1]


def test_quick_example_prints_what_the_readme_shows() -> None:
    section = (ROOT / "README.md").read_text().split("## Quick example", 1)[1]
    code, printed = re.findall(r"```(?:python)?\n(.*?)```", section, flags=re.S)[:2]
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout == printed


#: The README and the docs, the two folder READMEs among them.
DOCS = ("README.md", "docs/*.md", "benchmarks/README.md", "research/README.md")
#: A repository path in the text (a folder of the repository, then a file or folder name; ``[012]``
#: globs kept), not part of a longer path or of ``git show REV:path`` (an old commit's file).
CITED_PATH = re.compile(r"(?<![\w./:-])((?:sail_env|agents|benchmarks|research|tests|docs)/[\w./*-]*(?:\[\w-]+\])?[\w*]*)")
CITED_MODULE = re.compile(r"python3? -m ((?:sail_env|agents|benchmarks|research)(?:\.\w+)+)")
LINK = re.compile(r"\]\(([^)#\s]+)")


def cited_paths_missing(doc: Path) -> list[str]:
    """The paths, ``python -m`` modules and relative links of ``doc`` that name nothing in the tree."""
    text, missing = doc.read_text(), []
    for path in CITED_PATH.findall(text):
        path = path.rstrip(".")
        if not any(list(base.glob(path)) if any(c in path for c in "*[") else (base / path).exists()
                   for base in (ROOT, doc.parent)):  # from the root, or a link from the doc's folder
            missing.append(path)
    for module in CITED_MODULE.findall(text):
        base = ROOT / module.replace(".", "/")
        if not (base.with_suffix(".py").is_file() or (base / "__main__.py").is_file() or (base / "__init__.py").is_file()):
            missing.append(f"python -m {module}")
    for link in LINK.findall(text):
        if "://" not in link and not (doc.parent / link).exists():
            missing.append(f"({link})")
    return missing


def test_the_docs_cite_paths_that_exist() -> None:
    """A moved or removed script, result or module fails here until the docs follow it."""
    docs = [doc for pattern in DOCS for doc in sorted(ROOT.glob(pattern))]
    assert len(docs) >= 8
    assert {str(doc.relative_to(ROOT)): cited_paths_missing(doc) for doc in docs} == {str(doc.relative_to(ROOT)): [] for doc in docs}


def readme_section(path: Path, name: str) -> str:
    """The text between a file's generated-section markers of ``name``."""
    start, end = cli.section_markers(name)
    return path.read_text().split(start, 1)[1].split(end, 1)[0].strip()


def test_the_results_table_is_the_kept_results_rendered() -> None:
    """Every number of the README's results table, its notes included, is what
    ``python -m benchmarks.results_table`` renders from the kept results: a number edited by hand,
    or a kept result changed without rendering again, fails here."""
    assert readme_section(ROOT / "README.md", results_table.SECTION) == results_table.render()


def kept_rates(env: str) -> dict[str, list[float]]:
    """Success rates by agent (a learner: one per seed) read straight from the kept file holding
    ``env``, not through benchmarks.results_table: the latest finished trial of each grid cell, or
    benchmarks.ceiling's rows."""
    if env in results_table.UNCERTAIN_TASKS:
        agents = json.loads(results_table.UNCERTAIN.read_text())[env]["agents"]
        rates = {name: [row["success_rate"]] for name, row in agents.items() if not name.endswith(".zip")}
        for label, _, runs in results_table.UNCERTAIN_LEARNERS[env]:
            rates[label] = [agents[run]["success_rate"] for run in runs]
        return rates
    for path in results_table.GRIDS.values():
        kept = json.loads(path.read_text())
        if env in kept["user_attrs"]["settings"]["envs"]:
            latest = {t["user_attrs"]["cell"]: t for t in kept["trials"] if t["state"] == "COMPLETE"}
            rates: dict[str, list[float]] = {}
            for trial in latest.values():
                if trial["params"]["env"] == env and trial["params"]["hyperparameters"] in ("none", "tuned"):
                    agent = trial["params"]["agent"]
                    name = results_table.NAMES[agent] if trial["params"]["hyperparameters"] == "tuned" else agent
                    rates.setdefault(name, []).append(trial["user_attrs"]["summary"]["success_rate"])
            if env in results_table.BESIDE_GRIDS:  # learners evaluated apart, on the same episodes
                beside, learners = results_table.BESIDE_GRIDS[env]
                agents = json.loads(beside.read_text())[env]["agents"]
                for label, _, runs in learners:
                    rates[label] = [agents[run]["success_rate"] for run in runs]
            return rates
    raise AssertionError(f"no kept result holds {env}")


def test_each_rate_in_the_results_table_is_its_kept_result() -> None:
    """A second route to the same files: the passive, LQR and LQG columns, the best classical design,
    the best learner's mean over its seeds and the ceiling of every row equal the success rates
    stored in the kept result the row comes from."""
    rows = [line for line in readme_section(ROOT / "README.md", results_table.SECTION).splitlines()
            if line.startswith("| `")]
    assert [row.split(" | ")[0].strip("| `") for row in rows] == list(results_table.TASKS)
    for row in rows:
        cells = [cell.strip() for cell in row.strip("|").split(" | ")]
        rates = kept_rates(cells[0].strip("`"))
        for cell, agent in zip(cells[1:4], ("passive", "lqr", "lqg")):
            assert cell == f"{100 * rates[agent][0]:.1f} %", (cells[0], agent)
        design, design_rate = cells[4].rsplit(" ", 2)[0], cells[4].rsplit(" ", 2)[1]
        design_name = {v: k for k, v in results_table.NAMES.items()}.get(design, design)
        assert design_rate == f"{100 * rates[design_name][0]:.1f}", (cells[0], design)
        if not cells[5].startswith("queued") and cells[5] != "–":
            label, mean = re.match(r"(.*) (\d+\.\d) %", cells[5]).groups()
            assert mean == f"{100 * np.mean(rates[label]):.1f}", (cells[0], label)
        bounds = [rates[name][0] for name in results_table.BOUNDS if name in rates] or rates["lqr"]
        assert cells[7].startswith(f"{100 * max(bounds):.1f} %"), cells[0]


def test_a_learner_beside_a_grid_counts_only_on_the_grids_episodes() -> None:
    """The file of learners evaluated apart must hold the grid's LQG outcomes, episode by episode: one
    episode's outcome changed in the grid's LQG, and the row is refused."""
    env = next(iter(results_table.BESIDE_GRIDS))
    path, learners = results_table.BESIDE_GRIDS[env]
    task = results_table.grid_tasks(results_table.GRIDS["realistic"])[env]
    assert len(results_table.beside_grid(task, env, path, learners).learners) == len(task.learners) + len(learners)
    lqg = task.classical["lqg"].copy()
    lqg[0] = not lqg[0]
    other = dataclasses.replace(task, classical={**task.classical, "lqg": lqg})
    with pytest.raises(ValueError, match="not the grid's"):
        results_table.beside_grid(other, env, path, learners)


def test_every_registered_id_is_in_the_task_table_or_named_as_kept_for_comparison() -> None:
    """The README names each id once: in the task table, or in the one paragraph on the ids kept for
    comparison, each of which has a newer version registered (the versioning rule)."""
    import gymnasium as gym

    import sail_env  # noqa: F401

    readme = (ROOT / "README.md").read_text().split("## The task suite", 1)[1].split("### Results", 1)[0]
    table = set(re.findall(r"^\| `(LightSail[\w-]+)`", readme, flags=re.M))
    kept = set(re.findall(r"`(LightSail[\w-]+-v\d+)`", readme.split("for comparison only", 1)[1].split("\n\n", 1)[0]))
    registered = {name for name in gym.registry if name.startswith("LightSail")}
    assert table | kept == registered and not table & kept
    for name in kept:
        stem, version = name.rsplit("-v", 1)
        assert f"{stem}-v{int(version) + 1}" in registered, name


@pytest.mark.parametrize(("study", "doc", "section"), [("realistic", "docs/learners.md", "realistic-table"),
                                                        ("3d", "docs/tasks.md", "3d-table")])
def test_the_docs_grid_tables_are_their_kept_exports_rendered(study: str, doc: str, section: str) -> None:
    """A grid's table in the docs is what ``agents.grid import`` and ``render`` make of its kept
    export (here into memory, as they would into a fresh clone's runs/grid.db)."""
    import optuna

    from agents import grid, kept

    storage = optuna.storages.InMemoryStorage()
    grid.import_grid(storage, study, kept.read(results_table.GRIDS[study], study, "--file"))
    assert readme_section(ROOT / doc, section) == grid.table_markdown(optuna.load_study(storage=storage,
                                                                                          study_name=study))


def test_pyprojects_mutation_settings_name_files_and_sections_that_exist() -> None:
    """``[tool.mutmut]`` names modules and tests that exist (a module moved or renamed would silently
    drop out of the mutation run), and each pointer to a doc's section finds that section."""
    import tomllib

    text = (ROOT / "pyproject.toml").read_text()
    mutmut = tomllib.loads(text)["tool"]["mutmut"]
    selection = mutmut["pytest_add_cli_args_test_selection"]
    deselected = selection[selection.index("--deselect") + 1]
    tests = [arg for arg in selection if arg.startswith("tests/") and arg != deselected]
    assert [path for path in (*mutmut["only_mutate"], *tests, deselected.split("::")[0])
            if not (ROOT / path).exists()] == []
    assert f"def {deselected.split('::')[1]}(" in (ROOT / deselected.split("::")[0]).read_text()
    pointers = re.findall(r"(docs/[\w.-]+\.md),? \"([^\"]+)\"", text)
    assert len(pointers) == 2
    for doc, section in pointers:
        assert f"## {section}\n" in (ROOT / doc).read_text(), (doc, section)
    assert "README \"" not in text
