"""Smoke tests of evaluate.py: two paired episodes, the report files, clear errors for bad models."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
from agents import evaluation as evaluate
from agents import training as train


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("run")
    assert train.main(["--algo", "ppo", "--timesteps", "256", "--n-envs", "2", "--eval-freq", "0",
                       "--out", str(out), "--no-progress-bar"]) == 0
    return out / "final_model.zip"


def _strict_json(path: Path) -> dict:
    def reject(constant: str) -> None:
        raise ValueError(f"non-standard JSON constant {constant}")
    return json.loads(path.read_text(), parse_constant=reject)


def test_report_of_baselines_and_a_trained_agent(model: Path, tmp_path: Path) -> None:
    out = tmp_path / "report"
    assert evaluate.main(["--agent", "passive", "--agent", "lqr", "--agent", str(model),
                          "--episodes", "2", "--out", str(out)]) == 0
    report = _strict_json(out / "report.json")
    assert report["env"] == "LightSail-v0" and "versions" in report and report["config"]["episodes"] == 2
    assert len(report["agents"]) == 3
    for summary in report["agents"].values():
        assert summary["episodes"] == 2 and 0 <= summary["success_ci95"][0] <= summary["success_rate"]
        assert set(summary["terminal_pointing_rad"]) == {"median", "p90", "max"}
        assert math.isfinite(summary["mean_return"])
    assert report["agents"]["lqr"]["success_rate"] == 1.0
    with (out / "episodes.csv").open() as file:
        rows = list(csv.DictReader(file))
    assert len(rows) == 6
    # Paired: every agent starts episode i from the same state.
    assert len({(r["episode"], r["x0"], r["theta0"], r["cutoff_s"]) for r in rows}) == 2
    for name in ("report.md", "pointing.png", "trajectories.png", "success_vs_tilt.png"):
        assert (out / name).is_file()
    assert "| lqr | 100.0%" in (out / "report.md").read_text()


def test_lqg_on_the_realistic_task(tmp_path: Path) -> None:
    assert evaluate.main(["--env", "LightSailRealistic-v0", "--agent", "lqg", "--episodes", "2",
                          "--out", str(tmp_path)]) == 0
    assert _strict_json(tmp_path / "report.json")["agents"]["lqg"]["episodes"] == 2


def test_diverged_episodes_are_null_in_json() -> None:
    episodes = [{"success": False, "diverged": True, "terminal_pointing_rad": math.inf, "return": -10.0}]
    summary = evaluate.summarise(episodes)
    assert summary["terminal_pointing_rad"] == {"median": None, "p90": None, "max": None}
    json.dumps(summary, allow_nan=False)


def test_wilson_interval() -> None:
    assert evaluate.wilson_interval(10, 10)[1] == 1.0
    lo, hi = evaluate.wilson_interval(87, 100)
    assert lo == pytest.approx(0.7911, abs=1e-3) and hi == pytest.approx(0.9221, abs=1e-3)


@pytest.mark.parametrize("content", [None, b"not a zip file"])
def test_missing_or_corrupt_model_is_a_one_line_error(content: bytes | None, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "model.zip"
    if content is not None:
        path.write_bytes(content)
    assert evaluate.main(["--agent", "lqr", "--agent", str(path), "--episodes", "2", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert str(path) in err and "\n" not in err
    assert not (tmp_path / "report.json").exists()
