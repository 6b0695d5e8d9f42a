"""The benchmark scripts a user runs (benchmarks/) run on a tiny budget: they import the library, and a
refactoring that breaks them fails here rather than when someone re-measures. The research scripts'
tests are in research/tests/, off the default run."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from benchmarks import cross_kernel, speed

ROOT = Path(__file__).resolve().parents[1]


def test_two_blas_kernels_play_the_same_episodes(tmp_path, capsys):
    """Two children under two OpenBLAS kernels (Prescott's generic one against this machine's):
    the noisy planar task's pointing to 5e-10 (measured on 200 episodes), far inside the bound."""
    summary = cross_kernel.main(["--episodes", "3", "--tasks", "LightSailRealistic-v0", "--out", str(tmp_path)])
    assert summary["tasks"]["LightSailRealistic-v0"]["max_relative_difference"] < cross_kernel.SAME_EPISODES
    assert (tmp_path / "cross_kernel_passive.json").is_file()


def test_speed_takes_turns_and_writes_its_tables_into_the_readme(tmp_path, capsys, monkeypatch):
    """Peer and subject alternate (A, B, A, B): a burst of load on the machine cannot favour one."""
    order = []
    timed = speed.timed
    monkeypatch.setattr(speed, "timed", lambda work: (order.append(work), timed(work))[1])
    readme = tmp_path / "README.md"
    readme.write_text("before\n<!-- speed-table:start -->\nold\n<!-- speed-table:end -->\nafter\n")
    args = ["--quick", "--sections", "single", "--tasks", "LightSail-v0", "--out", str(tmp_path / "speed.json"),
            "--readme", str(readme)]
    assert speed.main(args) == 0
    assert len(order) == 4 and order[0] is order[2] and order[1] is order[3] and order[0] is not order[1]
    text = readme.read_text()
    assert text.startswith("before\n<!-- speed-table:start -->\nMeasured on ") and text.endswith("after\n")
    assert "| LightSail-v0 | " in text and "old" not in text
    rounds = __import__("json").loads((tmp_path / "speed.json").read_text())["single"]["LightSail-v0"]
    assert len(rounds["LightSail-v0"]["rounds"]) == 2 and rounds["CartPole-v1"]["rate"] > 0


def test_speed_refuses_a_readme_without_its_markers_before_measuring(tmp_path, capsys):
    readme = tmp_path / "README.md"
    readme.write_text("no markers\n")
    assert speed.main(["--quick", "--readme", str(readme), "--out", str(tmp_path / "s.json")]) == 2
    assert "speed-table:start" in capsys.readouterr().err and not (tmp_path / "s.json").exists()


def test_learning_curves_average_the_seeds_and_draw_the_report_lines(tmp_path, capsys):
    """Two seeds' evaluations.npz (one evaluated further than the other) and an evaluate.py report:
    the curve stops at the steps both reached, and the printed summary is their mean."""
    from benchmarks import learning_curves

    for seed, rates in enumerate(([0.2, 0.6, 0.8], [0.4, 0.8])):
        run = tmp_path / f"run-seed{seed}"
        run.mkdir()
        successes = np.array([[1] * round(10 * r) + [0] * (10 - round(10 * r)) for r in rates])
        np.savez(run / "evaluations.npz", timesteps=10_000 * np.arange(1, len(rates) + 1), successes=successes)
    report = tmp_path / "report.json"
    report.write_text(json.dumps({"agents": {"lqg": {"success_rate": 0.84, "episodes": 500}}}))
    out = tmp_path / "curve.png"
    assert learning_curves.main(["--env", "LightSail-v0", "--runs", f"PPO={tmp_path}/run-seed*",
                                 "--report", str(report), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "2 seeds to 20,000 steps; last evaluation 70.0 % (seeds 60, 80)" in printed
    assert out.stat().st_size > 10_000
    assert learning_curves.main(["--env", "LightSail-v0", "--runs", "no-equals-sign", "--out", str(out)]) == 2


def test_learning_curves_from_a_grid_export_take_each_cells_latest_trial(tmp_path, capsys):
    """With --grid the glob picks cells by name; a cell run twice (redo) counts once, by its latest
    trial; a cell without intermediate values (no evaluations) or of another name is left out."""
    from benchmarks import learning_curves

    def trial(cell, curve):
        return {"user_attrs": {"cell": cell}, "intermediate_values": {str(10_000 * (i + 1)): r for i, r in enumerate(curve)}}

    export = tmp_path / "grid.json"
    export.write_text(json.dumps({"study": "g", "user_attrs": {}, "trials": [
        trial("T-sac-tuned-0", [0.0, 0.0]),  # replaced by its redo below
        trial("T-sac-tuned-1", [0.4, 0.8]),
        trial("T-sac-tuned-0", [0.2, 0.6, 0.8]),
        trial("T-sac-tuned-2", []),
        trial("T-ppo-tuned-0", [1.0, 1.0])]}))
    out = tmp_path / "curve.png"
    assert learning_curves.main(["--env", "T", "--grid", str(export), "--runs", "SAC=T-sac-tuned-*",
                                 "--out", str(out)]) == 0
    assert "SAC: 2 seeds to 20,000 steps; last evaluation 70.0 % (seeds 60, 80)" in capsys.readouterr().out
    assert learning_curves.main(["--env", "T", "--grid", str(export), "--runs", "TD3=T-td3-*", "--out", str(out)]) == 2
    assert "no run with a learning curve" in capsys.readouterr().err


def test_reference_lines_near_100_percent_stay_off_the_frame_and_are_named_together(tmp_path, capsys, monkeypatch):
    """The adaptive LQG and both bounds at 98-99 % once merged into the top of the frame: the axis now
    runs above 100 %, and lines too close to tell apart are named together above them; a line two
    points or more from its neighbours is not. The steps' axis is linear unless --log-steps; a legend
    below the axes leaves them the figure's width."""
    from benchmarks import learning_curves

    figures = []
    subplots = learning_curves.plt.subplots
    monkeypatch.setattr(learning_curves.plt, "subplots", lambda *a, **k: figures.append(subplots(*a, **k)) or figures[-1])
    export = tmp_path / "grid.json"
    export.write_text(json.dumps({"study": "g", "user_attrs": {}, "trials": [
        {"user_attrs": {"cell": f"T-ppo-tuned-{seed}"}, "intermediate_values": {"10000": 0.5, "20000": 0.9}}
        for seed in range(2)]}))
    report = tmp_path / "report.json"
    report.write_text(json.dumps({"agents": {name: {"success_rate": rate, "episodes": 500} for name, rate in
                                             (("lqg", 0.826), ("lqg-mm", 0.986), ("lqr-oracle", 0.992),
                                              ("lqg-oracle", 0.984))}}))
    assert learning_curves.main(["--env", "T", "--grid", str(export), "--runs", "PPO=T-ppo-*", "--report", str(report),
                                 "--out", str(tmp_path / "curve.png")]) == 0
    (fig, ax), = figures
    assert ax.get_ylim()[1] >= 105 and ax.get_xscale() == "linear"
    notes = [text.get_text() for text in ax.texts]
    assert notes == ["ceiling: LQG oracle / adaptive LQG (lqg-mm) / ceiling: LQR oracle: 98.4–99.2 %, on top of each other"]
    assert learning_curves.bundles({"a": (0.5, 1), "b": (0.52, 1), "c": (0.53, 1)}) == [["b", "c"]]
    assert learning_curves.main(["--env", "T", "--grid", str(export), "--log-steps", "--legend", "below",
                                 "--runs", "PPO, with a label as long as the docs' figures have=T-ppo-*",
                                 "--report", str(report), "--out", str(tmp_path / "log.png")]) == 0
    assert figures[-1][1].get_xscale() == "log"
    # A legend below the axes is laid out after them: it once squeezed them to 65 % of the figure's width.
    assert figures[-1][1].get_position().width > 0.8


def test_every_reference_line_has_a_style():
    """zip() would drop a reference without one, silently (the fourth, lqg-oracle, once was)."""
    from benchmarks import learning_curves

    assert len(learning_curves.REFERENCE_STYLES) >= len(learning_curves.REFERENCES)


def test_results_table_goes_between_the_markers_and_a_file_without_them_is_refused(tmp_path, capsys):
    """``python -m benchmarks.results_table --readme FILE`` puts the table between FILE's markers and
    leaves the rest; a file without them is one line on stderr, exit 2, and stays as it was."""
    from agents import cli
    from benchmarks import results_table

    start, end = cli.section_markers(results_table.SECTION)
    readme = tmp_path / "README.md"
    readme.write_text(f"before\n{start}\nold\n{end}\nafter\n")
    assert results_table.main(["--readme", str(readme)]) == 0
    assert readme.read_text() == f"before\n{start}\n{results_table.render()}\n{end}\nafter\n"
    plain = tmp_path / "plain.md"
    plain.write_text("no markers\n")
    capsys.readouterr()
    assert results_table.main(["--readme", str(plain)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no <!-- results-table:start -->" in err and plain.read_text() == "no markers\n"


def test_gpu_check_stops_at_once_without_a_gpu(tmp_path: Path) -> None:
    """On a CPU it said nothing for 180 s, then exited 124: now one line and exit 3, nothing measured."""
    pytest.importorskip("jax")
    done = subprocess.run(["bash", str(ROOT / "benchmarks" / "gpu_check.sh")], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "OUT": str(tmp_path / "out")})
    assert done.returncode == 3 and "no GPU" in done.stderr
    assert not (tmp_path / "out" / "speed_jax_gpu.json").exists()
