"""Smoke tests of evaluate.py: two paired episodes, the report files, clear errors for bad models."""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import warnings

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

ROOT = Path(__file__).resolve().parents[1]
from agents import LQGAgent
from agents import evaluation as evaluate
from agents import training as train
from agents.sb3 import ModelLoadError, SB3Agent, normalizer_path
from sail_env.tasks import TASKS


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A PPO model trained for a few hundred steps with VecNormalize, in train.py's run layout."""
    out = tmp_path_factory.mktemp("run") / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "256", "--n-envs", "2", "--eval-freq", "0",
                       "--out", str(out), "--no-progress-bar"]) == 0
    return next(out.rglob("final_model.zip"))


@pytest.fixture
def run_copy(model: Path, tmp_path: Path) -> Path:
    """The model in a copy of its run folder, for tests that damage it."""
    copy = tmp_path / "run"
    shutil.copytree(model.parent, copy)
    return copy / model.name


@pytest.fixture(scope="module")
def stacked_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A PPO model trained for a few hundred steps on the last three normalised observations (frame_stack: 3)."""
    return _tiny_run(tmp_path_factory.mktemp("stacked"), "ppo", "policy: MlpPolicy\n  frame_stack: 3\n"
                     "  policy_kwargs: {net_arch: [16, 16]}", "--eval-freq", "0")


def _tiny_run(folder: Path, algo: str, entry: str, *flags: str) -> Path:
    """The final model of a 256-step run on LightSail-v0 (2 envs, rollouts of 64) with ``entry``'s lines."""
    (folder / "hp.yml").write_text(f"LightSail-v0:\n  n_timesteps: 256\n  normalize: true\n  n_steps: 64\n"
                                   f"  batch_size: 64\n  {entry}\n")
    assert train.main(["--algo", algo, "--timesteps", "256", "--n-envs", "2", "--config", str(folder / "hp.yml"),
                       "--out", str(folder / "run"), "--no-progress-bar", *flags]) == 0
    return folder / "run" / "final_model.zip"


def _plays_alone_as_in_a_batch(agent: SB3Agent) -> None:
    """One observation (D,) at a time (the trajectory) or a batch (N, D): the same episodes."""
    batched = evaluate.run_batch("LightSail-v0", agent, 2, 11)
    for episode in batched:
        alone = evaluate.run_episode(gym.make("LightSail-v0"), agent, episode["seed"])
        assert alone["success"] == episode["success"] and np.isclose(alone["return"], episode["return"], rtol=1e-5)


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
    assert "| lqr | 100.0% | 34.2%–100.0% | 100.0%" in (out / "report.md").read_text()
    # The expected success beside the sampled one (a fixed coast: the same), and each agent's paired
    # differences from the first, both ways.
    assert report["agents"]["lqr"]["expected_success"] == 1.0 and {r["expected_success"] for r in rows} <= {"0.0", "1.0"}
    paired = report["paired"]
    assert paired["reference"] == "passive" and len(paired["agents"]) == 2
    lqr = paired["agents"]["lqr"]
    assert set(lqr) == {"success", "expected_success"} and "mcnemar_p" in lqr["success"]
    assert lqr["success"]["difference"] == lqr["expected_success"]["difference"] == 1.0 - report["agents"]["passive"][
        "success_rate"]
    assert "Paired differences from passive" in (out / "report.md").read_text()


def test_the_expected_success_of_a_noisy_coast_is_reported_with_its_interval(tmp_path: Path) -> None:
    """LightSailUncertain-v2: the expected success is each episode's share of 4 further coasts, within
    [0, 1], its interval around it; with --expected-paths 0 it is not reported."""
    assert evaluate.main(["--env", "LightSailUncertain-v2", "--agent", "passive", "--episodes", "2",
                          "--expected-paths", "4", "--out", str(tmp_path / "a"), "--no-progress-bar"]) == 0
    summary = _strict_json(tmp_path / "a" / "report.json")["agents"]["passive"]
    lo, hi = summary["expected_success_ci95"]
    assert 0 <= lo <= summary["expected_success"] <= hi <= 1
    with (tmp_path / "a" / "episodes.csv").open() as file:
        assert all(float(r["expected_success"]) * 4 % 1 == 0 for r in csv.DictReader(file))
    assert evaluate.main(["--env", "LightSailUncertain-v2", "--agent", "passive", "--episodes", "2",
                          "--expected-paths", "0", "--out", str(tmp_path / "b"), "--no-progress-bar"]) == 0
    report = _strict_json(tmp_path / "b" / "report.json")
    assert "expected_success" not in report["agents"]["passive"] and report["paired"] == {}


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
    out = tmp_path / "report"
    assert evaluate.main(["--agent", "lqr", "--agent", str(path), "--episodes", "2", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert str(path) in err and "\n" not in err
    assert not out.exists()


def test_a_missing_model_is_named_with_the_models_its_folder_holds(model: Path, tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A short run saves no best_model.zip, and the README's next command names it (issue 42)."""
    (tmp_path / "latest").symlink_to(model.parent, target_is_directory=True)
    err = _refused(["--agent", str(tmp_path / "latest" / "best_model.zip"), "--out", str(tmp_path / "report")],
                   capsys, monkeypatch)
    assert f"{tmp_path / 'latest'} holds final_model.zip: pass one of those" in err
    (tmp_path / "empty").mkdir()
    err = _refused(["--agent", str(tmp_path / "empty" / "best_model.zip")], capsys, monkeypatch)
    assert f"{tmp_path / 'empty'} holds no model (.zip, or a JAX run's .npz)" in err


# ---------------------------------------------------------------------- command-line errors
@pytest.mark.parametrize("content", [b"", b"PK\x03\x04 cut short"])
def test_an_empty_or_cut_policy_npz_is_one_line(content: bytes, tmp_path: Path, capsys: pytest.CaptureFixture,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A JAX run's policy.npz that is empty or cut short (EOFError, BadZipFile tracebacks before)."""
    policy = tmp_path / "policy.npz"
    policy.write_bytes(content)
    err = _refused(["--agent", str(policy), "--out", str(tmp_path / "report")], capsys, monkeypatch)
    assert "empty, cut short or not an .npz file" in err


def test_a_runs_policy_and_best_policy_are_two_agents_and_a_nan_one_is_named(tmp_path: Path,
                                                                               capsys: pytest.CaptureFixture) -> None:
    """JAX policies are named as SB3's models, ``algo:run/stem`` (a run's two were refused as one name); an
    agent whose actions are not finite is named in the one-line error (it said "actions must be finite")."""
    from agents.mlp_policy import save_policy

    run = tmp_path / "LightSail-v0-jax_ppo-0"
    run.mkdir()
    for stem, bias in (("policy", 0.0), ("best_policy", 0.1), ("nan_policy", np.nan)):
        save_policy(run / f"{stem}.npz", {"w0": np.zeros((5, 2)), "b0": np.array([bias, 0.0])},
                    {"env_id": "LightSail-v0", "algo": "jax_ppo"})
    assert evaluate.main(["--agent", str(run / "policy.npz"), "--agent", str(run / "best_policy.npz"), "--episodes",
                          "1", "--out", str(tmp_path / "report"), "--no-progress-bar"]) == 0
    names = set(_strict_json(tmp_path / "report" / "report.json")["agents"])
    assert names == {"jax_ppo:LightSail-v0-jax_ppo-0/policy", "jax_ppo:LightSail-v0-jax_ppo-0/best_policy"}
    capsys.readouterr()
    assert evaluate.main(["--agent", "lqr", "--agent", str(run / "nan_policy.npz"), "--episodes", "1",
                          "--out", str(tmp_path / "nan"), "--no-progress-bar"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: jax_ppo:LightSail-v0-jax_ppo-0/nan_policy: action") and "finite" in err
    assert not (tmp_path / "nan").exists()


def _refused(argv: list[str], capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run evaluate.py expecting a refusal before any episode: exit 2, one line on stderr; that line."""
    def no_episodes(*args: object) -> None:
        raise AssertionError("an episode ran before the refusal")
    monkeypatch.setattr(evaluate, "run_batch", no_episodes)
    assert evaluate.main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("error: ") and "\n" not in err and "Traceback" not in err
    assert captured.out == ""
    return err


@pytest.mark.parametrize("argv, message", [
    (["--env", "Bogus-v0", "--agent", "lqr"], "--env must be one of LightSail-v0, LightSailDeepDish-v0"),
    (["--env", "CartPole-v1", "--agent", "lqr"], "got 'CartPole-v1'"),
    (["--seed", "-1", "--agent", "lqr"], "--seed must be >= 0, got -1"),
    (["--episodes", "0", "--agent", "lqr"], "--episodes must be >= 1"),
    (["--episodes", "ten", "--agent", "lqr"], "invalid int value: 'ten'"),
    ([], "the following arguments are required: --agent"),
    (["--agent", "lqr", "--bogus"], "unrecognized arguments: --bogus"),
    (["--agent", "lqx"], "lqx: neither a baseline (passive, lqr, lqg, lqr-oracle, lqg-oracle, lqg-mm, lqg-mm-offset) nor a model file"),
    (["--agent", "lqr", "--agent", "lqr"], "agent names must be distinct"),
    (["--agent", "lqr", "--expected-paths", "-1"], "--expected-paths must be in [0, 1024], got -1"),
])
def test_bad_arguments_are_one_line_and_exit_2_with_nothing_written(
        argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "report"
    assert message in _refused([*argv, "--out", str(out)], capsys, monkeypatch)
    assert not out.exists()


def test_out_under_a_file_is_refused_before_any_episode(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "file").write_text("")
    err = _refused(["--agent", "lqr", "--out", str(tmp_path / "file" / "report")], capsys, monkeypatch)
    assert f"{tmp_path / 'file'} is not a directory" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_out_where_nothing_can_be_written_is_refused_before_any_episode(capsys: pytest.CaptureFixture,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    out = Path("/sys/lightsail-report")  # sysfs refuses new files, even to root
    try:
        with tempfile.NamedTemporaryFile(dir="/sys"):
            pytest.skip("/sys is writable here")
    except OSError:
        pass
    assert "--out /sys/lightsail-report: cannot write in /sys" in _refused(["--agent", "lqr", "--out", str(out)],
                                                                           capsys, monkeypatch)
    assert not out.exists()


# ---------------------------------------------------------------------- the report: whole or not at all
def _files(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones too) with its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _agents_of_report(out: Path) -> tuple[list[str], list[str], list[str]]:
    """The agents report.json, episodes.csv and report.md name: the same when the report is one run's."""
    with (out / "episodes.csv").open() as file:
        in_csv = list(dict.fromkeys(row["agent"] for row in csv.DictReader(file)))
    in_md = [line.split(" | ")[0].removeprefix("| ") for line in (out / "report.md").read_text().splitlines()
             if line.startswith("| ") and not line.startswith("| agent")]
    return list(_strict_json(out / "report.json")["agents"]), in_csv, in_md


@pytest.fixture
def earlier(tmp_path: Path) -> Path:
    """A folder holding the report of an earlier evaluation (passive, two episodes)."""
    out = tmp_path / "reports" / "earlier"
    assert evaluate.main(["--agent", "passive", "--episodes", "2", "--out", str(out), "--no-progress-bar"]) == 0
    return out


def test_an_earlier_report_is_kept_unless_overwrite(earlier: Path, capsys: pytest.CaptureFixture,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """evaluate.py replaced an earlier report in the same --out without a word (issue 42)."""
    before = _files(earlier.parent)
    err = _refused(["--agent", "lqr", "--episodes", "2", "--out", str(earlier)], capsys, monkeypatch)
    assert f"--out {earlier} holds a report already: --overwrite replaces it" in err
    assert _files(earlier.parent) == before
    monkeypatch.undo()
    assert evaluate.main(["--agent", "lqr", "--episodes", "2", "--out", str(earlier), "--overwrite",
                          "--no-progress-bar"]) == 0
    assert _agents_of_report(earlier) == (["lqr"], ["lqr"], ["lqr"])
    assert sorted(p.name for p in earlier.parent.iterdir()) == ["earlier"]  # nothing left beside it


def test_without_out_the_same_command_again_keeps_the_earlier_report(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """The default --out numbers its folder as train.py's runs are numbered: the README's command
    run twice keeps both reports (an explicit --out that holds one is refused instead)."""
    monkeypatch.chdir(tmp_path)
    for _ in range(2):
        assert evaluate.main(["--agent", "passive", "--episodes", "2", "--no-progress-bar"]) == 0
    assert sorted(p.name for p in (tmp_path / "reports").iterdir()) == ["LightSail-v0", "LightSail-v0_2"]
    assert _agents_of_report(tmp_path / "reports" / "LightSail-v0_2") == (["passive"],) * 3


def test_an_out_holding_other_files_is_refused_even_with_overwrite(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "notes.txt").write_text("mine")
    err = _refused(["--agent", "lqr", "--out", str(tmp_path), "--overwrite"], capsys, monkeypatch)
    assert f"--out {tmp_path} holds files that are not a report's (notes.txt)" in err
    assert _files(tmp_path) == {"notes.txt": b"mine"}


@pytest.mark.parametrize("failure", [OSError(28, "No space left on device"), KeyboardInterrupt()],
                         ids=["disk full", "ctrl-c"])
def test_a_write_cut_short_leaves_the_earlier_report_as_it_was(failure: BaseException, earlier: Path,
                                                               capsys: pytest.CaptureFixture,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A failed write, or Ctrl-C while writing, left a half-written report.json beside the old files."""
    before = _files(earlier.parent)
    def cut_short(*args: object) -> None:
        raise failure
    monkeypatch.setattr(evaluate, "plot_success_vs_tilt", cut_short)
    code = evaluate.main(["--agent", "lqr", "--episodes", "2", "--out", str(earlier), "--overwrite",
                          "--no-progress-bar"])
    err = capsys.readouterr().err.strip()
    assert code == (130 if isinstance(failure, KeyboardInterrupt) else 2) and "\n" not in err
    assert err.startswith("error: ") and "--out is as it was" in err
    assert _files(earlier.parent) == before


def test_a_failed_write_leaves_no_folder_it_made(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    def disk_full(*args: object) -> None:
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(evaluate, "plot_pointing", disk_full)
    assert evaluate.main(["--agent", "lqr", "--episodes", "2", "--out", str(tmp_path / "a" / "b" / "report"),
                          "--no-progress-bar"]) == 2
    assert "No space left on device" in capsys.readouterr().err and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("overwrite", [False, True])
def test_two_evaluations_into_one_out_never_mix(overwrite: bool, tmp_path: Path, capsys: pytest.CaptureFixture,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Another evaluation publishes into --out while this one writes its plots. Both exited 0,
    leaving one's report.json beside the other's report.md (issue 42). Now this one refuses with
    one line (the other's report stays whole), or with --overwrite replaces it whole."""
    out, flags = tmp_path / "report", ["--overwrite"] if overwrite else []
    plot, others = evaluate.plot_success_vs_tilt, []
    def meanwhile(*args: object, **kwargs: object) -> None:
        if not others:  # the outer evaluation's call: the other one runs to its end now
            others.append(None)
            others[0] = evaluate.main(["--agent", "lqr", "--episodes", "2", "--out", str(out), "--no-progress-bar"])
        plot(*args, **kwargs)
    monkeypatch.setattr(evaluate, "plot_success_vs_tilt", meanwhile)
    code = evaluate.main(["--agent", "passive", "--episodes", "2", "--out", str(out), "--no-progress-bar", *flags])
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error")]
    winner = "passive" if overwrite else "lqr"
    assert others == [0] and _agents_of_report(out) == ([winner], [winner], [winner])
    assert sorted(p.name for p in out.iterdir()) == sorted(evaluate.REPORT_FILES)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]
    if overwrite:
        assert code == 0 and err == []
    else:
        assert code == 2 and len(err) == 1 and "another evaluation wrote its report there while this one ran" in err[0]


def test_ctrl_c_while_a_report_replaces_another_waits_for_the_swap(earlier: Path, tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """--overwrite moves the earlier report aside, then renames the new one into place: Ctrl-C
    between the two would leave neither at --out; it is raised once both are done."""
    staging = tmp_path / "reports" / ".staged"
    staging.mkdir()
    (staging / "report.json").write_text("{}")
    rename = Path.rename
    def interrupted_rename(self: Path, target: Path) -> Path:
        os.kill(os.getpid(), signal.SIGINT)
        return rename(self, target)
    monkeypatch.setattr(Path, "rename", interrupted_rename)
    # Python's own Ctrl-C handler, whatever started pytest (a shell's background job ignores SIGINT).
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            evaluate.publish(staging, earlier, overwrite=True)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert _files(earlier.parent) == {"earlier/report.json": b"{}"}


def test_help_shows_defaults_and_env_ids(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exit_:
        evaluate.main(["--help"])
    assert exit_.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: 200)" in text and f"(default: {evaluate.DEFAULT_SEED})" in text
    assert "(default: LightSail-v0)" in text and "(default: None)" not in text
    for env_id in TASKS:
        assert env_id in text


# ---------------------------------------------------------------------- models and their statistics
def test_missing_statistics_are_refused_naming_the_file(run_copy: Path, capsys: pytest.CaptureFixture,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    stats = normalizer_path(run_copy)
    stats.unlink()
    err = _refused(["--agent", str(run_copy), "--out", str(run_copy.parent / "report")], capsys, monkeypatch)
    assert f"{stats}: not found" in err and "run.json says the model was trained with VecNormalize" in err


def test_statistics_of_another_env_are_refused_naming_the_file_and_both_shapes(
        run_copy: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    stats = normalizer_path(run_copy)
    VecNormalize(DummyVecEnv([lambda: gym.make("LightSailRealistic-v0")])).save(str(stats))
    err = _refused(["--agent", str(run_copy), "--out", str(run_copy.parent / "report")], capsys, monkeypatch)
    assert f"{stats}: statistics of observations of shape (25,), the model's have shape (5,)" in err


def test_statistics_a_run_did_not_use_are_refused(run_copy: Path, capsys: pytest.CaptureFixture,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    record = run_copy.parent / "run.json"
    run = json.loads(record.read_text())
    run["config"]["hyperparams"]["normalize"] = False
    record.write_text(json.dumps(run))
    err = _refused(["--agent", str(run_copy), "--out", str(run_copy.parent / "report")], capsys, monkeypatch)
    assert f"{normalizer_path(run_copy)}: unexpected; {record} says the model was trained without" in err


def test_without_run_json_statistics_beside_the_model_are_used(run_copy: Path, tmp_path: Path) -> None:
    (run_copy.parent / "run.json").unlink()
    agent = SB3Agent.load(run_copy, (5,))
    assert agent.normalizer is not None and agent.trained_env is None


def test_without_run_json_or_statistics_raw_observations_need_the_flag(
        run_copy: Path, tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    (run_copy.parent / "run.json").unlink()
    normalizer_path(run_copy).unlink()
    argv = ["--agent", str(run_copy), "--episodes", "2", "--out", str(tmp_path / "report"), "--no-progress-bar"]
    with monkeypatch.context() as patch:
        err = _refused(argv, capsys, patch)
    assert f"{normalizer_path(run_copy)}: not found, and no run.json" in err and "--raw-observations" in err
    assert evaluate.main([*argv, "--raw-observations"]) == 0


def test_a_checkpoint_finds_the_run_json_above_it(run_copy: Path) -> None:
    checkpoint = run_copy.parent / "checkpoints" / "rl_model_256_steps.zip"
    checkpoint.parent.mkdir(exist_ok=True)
    shutil.copy(run_copy, checkpoint)
    shutil.copy(normalizer_path(run_copy), normalizer_path(checkpoint))
    agent = SB3Agent.load(checkpoint, (5,))
    assert agent.normalizer is not None and agent.trained_env == "LightSail-v0"


def test_a_model_evaluated_on_another_task_gets_one_warning_naming_both(model: Path, tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture) -> None:
    assert evaluate.main(["--env", "LightSailDeepDish-v0", "--agent", str(model), "--episodes", "2",
                          "--out", str(tmp_path), "--no-progress-bar"]) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1
    assert "trained on LightSail-v0" in warnings[0] and "evaluated here on LightSailDeepDish-v0" in warnings[0]


def test_the_right_task_gets_no_warning(model: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert evaluate.main(["--agent", str(model), "--episodes", "2", "--out", str(tmp_path), "--no-progress-bar"]) == 0
    assert capsys.readouterr().err == ""


# ---------------------------------------------------------------------- progress, batches, plots
def test_without_a_terminal_each_agent_reports_one_line_when_done(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture) -> None:
    assert evaluate.main(["--agent", "passive", "--agent", "lqr", "--episodes", "3", "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(" in ")[0] for line in lines] == ["passive: 3 episodes", "lqr: 3 episodes"]


def test_on_a_terminal_the_bar_alone_shows_progress(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """tqdm's close() sets ``disable``, which the log line was keyed on: a terminal got both (issue 42)."""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert evaluate.main(["--agent", "lqr", "--episodes", "2", "--out", str(tmp_path / "report")]) == 0
    err = capsys.readouterr().err
    assert "2/2" in err and "episodes in" not in err


def test_in_a_log_a_long_evaluation_says_how_far_it_is(capsys: pytest.CaptureFixture,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """2,000 episodes were minutes without a line in a log: a line every LOG_EVERY_S, then the total."""
    agent = evaluate.BASELINES["passive"](gym.make("LightSail-v0").unwrapped.episode_spec)
    monkeypatch.setattr(evaluate, "BATCH_EPISODES", 1)
    monkeypatch.setattr(evaluate, "LOG_EVERY_S", 0.0)
    evaluate.run_agent("LightSail-v0", agent, 3, 7)
    lines = [line.split(",")[0].split(" in ")[0] for line in capsys.readouterr().err.splitlines()]
    assert lines == ["passive: 1/3 episodes", "passive: 2/3 episodes", "passive: 3 episodes"]


def test_warnings_are_one_line_each_and_held_back_by_a_refusal(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """gymnasium's warning about an out-of-date env id was two lines (file, then code) on stderr."""
    make = gym.make
    def make_with_a_warning(*args: object, **kwargs: object) -> gym.Env:
        warnings.warn("\x1b[33mWARN: The environment is out of date.\nUpgrade.\x1b[0m", DeprecationWarning)
        return make(*args, **kwargs)
    monkeypatch.setattr(gym, "make", make_with_a_warning)
    argv = ["--agent", "lqr", "--episodes", "2", "--out", str(tmp_path / "report"), "--no-progress-bar"]
    assert evaluate.main(argv) == 0
    assert capsys.readouterr().err.splitlines()[0] == "warning: The environment is out of date. Upgrade."
    assert evaluate.main([*argv, "--agent", str(tmp_path / "missing.zip")]) == 2
    assert capsys.readouterr().err.startswith("error: ")


def test_an_out_of_date_id_and_a_model_of_another_task_are_one_line(model: Path, tmp_path: Path) -> None:
    """The real entry point: a planar model on LightSail3DRealistic-v0 printed three lines (issue 42)."""
    done = subprocess.run([sys.executable, str(ROOT / "evaluate.py"), "--env", "LightSail3DRealistic-v0",
                           "--agent", str(model), "--episodes", "1", "--out", str(tmp_path / "rapport-é")],
                          capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert done.returncode == 2 and done.stdout == "", done.stderr
    assert done.stderr.startswith("error: ") and done.stderr.count("\n") == 1, done.stderr
    assert "this model was trained on LightSail-v0" in done.stderr and not (tmp_path / "rapport-é").exists()


def test_batches_play_the_same_episodes_as_one_batch(monkeypatch: pytest.MonkeyPatch) -> None:
    agent = LQGAgent(gym.make("LightSailRealistic-v0").unwrapped.episode_spec)
    whole = evaluate.run_batch("LightSailRealistic-v0", agent, 5, 7)
    monkeypatch.setattr(evaluate, "BATCH_EPISODES", 2)
    assert evaluate.run_agent("LightSailRealistic-v0", agent, 5, 7, progress=False) == whole


def test_coinciding_curves_are_grouped() -> None:
    t = np.linspace(0, 1, 50)
    curves = {"a": t, "b": t + 0.005, "c": 1 - t, "d": t + 0.5}
    assert evaluate.coinciding(curves) == [["a", "b"]]
    assert evaluate.coinciding({"a": t, "b": t[:10]}) == []
    diverged = np.where(t > 0.9, np.inf, t)  # diverged episodes' pointing: no warning, still grouped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert evaluate.coinciding({"a": diverged, "b": diverged + 0.005}) == [["a", "b"]]


def test_agent_styles_differ_so_coinciding_curves_stay_visible() -> None:
    styles = evaluate.agent_styles(["passive", "lqr", "ppo"])
    for key in ("marker", "ls", "color"):
        assert len({s[key] for s in styles.values()}) == 3
    widths = [s["lw"] for s in styles.values()]
    assert widths == sorted(widths, reverse=True)  # the later, thinner curve is drawn on top


# ---------------------------------------------------------------------- runs/latest, another task, help
def test_a_model_reached_through_a_link_is_recorded_by_its_run(model: Path, tmp_path: Path) -> None:
    """``runs/latest/best_model.zip`` was reported as ``ppo:latest/best_model``: which run was that?"""
    (tmp_path / "latest").symlink_to(model.parent, target_is_directory=True)
    out = tmp_path / "report"
    assert evaluate.main(["--agent", str(tmp_path / "latest" / model.name), "--episodes", "2", "--out", str(out),
                          "--no-progress-bar"]) == 0
    report = _strict_json(out / "report.json")
    assert list(report["agents"]) == [f"ppo:{model.parent.name}/{model.stem}"]
    assert report["config"]["agents"] == [str(model.resolve())]


def test_a_model_of_another_observation_shape_names_its_task(model: Path, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    err = _refused(["--env", "LightSail3D-v0", "--agent", str(model), "--out", str(tmp_path / "report")],
                   capsys, monkeypatch)
    assert "trained on observations of shape (5,), this env has (9,)" in err
    assert "this model was trained on LightSail-v0: pass --env LightSail-v0" in err


def test_a_frame_stacked_agent_sees_what_vec_frame_stack_showed_in_training(
        stacked_model: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Fed the raw observations, SB3Agent gives its model what training's VecFrameStack gave it
    (oldest first, zeros before an episode's first; forgotten at reset), so it acts as the model
    does on those; two episodes each in two environments, reset between them as evaluate.py does."""
    agent = SB3Agent.load(stacked_model, (5,))
    seen: list[np.ndarray] = []
    predict = agent.model.predict
    monkeypatch.setattr(agent.model, "predict", lambda obs, **kw: (seen.append(np.array(obs)), predict(obs, **kw))[1])
    env = train.make_env("LightSail-v0", 2, 3, "batched", {}, 0.99, training=False, frame_stack=3)
    env.venv.obs_rms = agent.normalizer.obs_rms  # the selection env, as EvalCallback syncs it
    stacked, steps = env.reset(), 0
    for _ in range(2):
        done = np.zeros(2, dtype=bool)
        while not done.any():
            action = agent.act(env.venv.get_original_obs())
            np.testing.assert_array_equal(seen[-1], stacked)
            np.testing.assert_array_equal(action, predict(stacked, deterministic=True)[0])
            stacked, _, done, _ = env.step(action)
            steps += 1
        stacked = env.reset()
        agent.reset()
    env.close()
    assert steps > 6 and not np.any(seen[0][:, :10]) and np.all(seen[3][:, :10])


def test_a_frame_stacked_agent_plays_one_episode_as_in_a_batch(stacked_model: Path) -> None:
    """One observation (D,) at a time (the trajectory) or a batch (N, D): the same episode."""
    _plays_alone_as_in_a_batch(SB3Agent.load(stacked_model, (5,)))


@pytest.fixture(scope="module")
def recurrent_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A RecurrentPPO model (an LSTM of 8) trained for a few hundred steps."""
    return _tiny_run(tmp_path_factory.mktemp("recurrent"), "recurrent_ppo", "policy: MlpLstmPolicy\n"
                     "  policy_kwargs: {net_arch: [16, 16], lstm_hidden_size: 8}", "--eval-freq", "128",
                     "--eval-episodes", "2")


def test_a_recurrent_agent_carries_its_memory_through_an_episode_and_forgets_it_at_reset(recurrent_model: Path) -> None:
    """The LSTM state goes from one step to the next (a memoryless replay acts otherwise) and
    starts afresh at reset (the same first action twice); one episode alone plays as in a batch."""
    agent = SB3Agent.load(recurrent_model, (5,))
    assert agent.name.startswith("recurrent_ppo:")
    env = gym.make("LightSail-v0")
    obs, _ = env.reset(seed=5)
    carried, forgetful = [], []
    for _ in range(5):
        carried.append(agent.act(obs))
        fresh = SB3Agent.load(recurrent_model, (5,))
        forgetful.append(fresh.act(obs))
        obs, *_ = env.step(carried[-1])
    np.testing.assert_array_equal(carried[0], forgetful[0])
    assert not np.array_equal(np.array(carried[1:]), np.array(forgetful[1:]))
    agent.reset()
    np.testing.assert_array_equal(agent.act(env.reset(seed=5)[0]), carried[0])
    _plays_alone_as_in_a_batch(agent)


def test_a_frame_stacked_model_needs_its_run_json_to_know_the_stack(stacked_model: Path, tmp_path: Path) -> None:
    copy = tmp_path / "run"
    shutil.copytree(stacked_model.parent, copy)
    (copy / "run.json").unlink()
    with pytest.raises(ModelLoadError, match=r"shape \(15,\), this env has \(5,\)"):
        SB3Agent.load(copy / stacked_model.name, (5,))
    with pytest.raises(ModelLoadError, match=r"shape \(15,\) \(3 stacked\), this env has \(9,\)"):
        SB3Agent.load(stacked_model, (9,))


def test_help_has_no_restructuredtext_markup(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit):
        evaluate.main(["--help"])
    text = capsys.readouterr().out
    assert "``" not in text and "--agent is passive, lqr, lqg" in text


def test_a_diverged_pointing_has_no_unit() -> None:
    assert evaluate.fmt_rad(None) == "diverged" and evaluate.fmt_rad(1.5e-10) == "1.50e-10 rad"


def test_trajectory_markers_are_not_a_regular_sampling_that_aliases_the_oscillation() -> None:
    """Markers every 0.1 s sampled the 0.089 s oscillation into a false slow wave (issue 20)."""
    from agents.evaluation import TRAJECTORY_MARKERS, marker_steps

    for curve in range(3):
        steps = marker_steps(201, curve)
        assert len(steps) == TRAJECTORY_MARKERS and 0 <= steps[0] and steps[-1] <= 200
        assert len(set(np.diff(steps))) > TRAJECTORY_MARKERS // 2  # no regular stride
    assert marker_steps(201, 0) != marker_steps(201, 1) and marker_steps(3, 0) == [0, 1, 2]


def test_the_plots_name_their_env_the_3d_axis_and_coinciding_curves(tmp_path: Path, monkeypatch) -> None:
    """Issue 20: the 3D plots showed the planar labels, no plot named its env, and the pointing plot
    never said that LQR and LQG coincide on LightSail3D-v0."""
    import matplotlib.pyplot as plt

    from agents import evaluation

    figures = []
    monkeypatch.setattr(plt.Figure, "savefig", lambda fig, *args, **kwargs: figures.append(fig))
    monkeypatch.setattr(plt, "close", lambda fig=None: None)
    steps = np.column_stack([np.linspace(0.0, 1.0, 50), *np.random.default_rng(0).normal(size=(8, 50))])
    evaluation.plot_trajectories({"lqr": steps, "lqg": steps}, tmp_path / "t.png", "LightSail3D-v0", three_d=True)
    episodes = [{"terminal_pointing_rad": p, "success": p < 1e-8, "theta_x0": 1e-3, "theta_y0": 0.0}
                for p in (1e-12, 2e-12, 1e-7)]
    evaluation.plot_pointing({"lqr": episodes, "lqg": episodes}, tmp_path / "p.png", "LightSail3D-v0")
    evaluation.plot_success_vs_tilt({"lqr": episodes}, tmp_path / "s.png", "LightSail3D-v0", three_d=True)
    trajectory, pointing, tilt = figures
    assert [ax.get_ylabel() for ax in trajectory.axes][:4] == ["x [mm]", "y [mm]", "θy [mrad]", "θx [mrad]"]
    assert "3D" in trajectory.axes[0].get_title(loc="left")
    assert all("LightSail3D-v0" in [t.get_text() for t in fig.texts] for fig in figures)
    assert "lqr = lqg" in pointing.axes[0].get_title(loc="right")
    assert "total tilt" in tilt.axes[0].get_xlabel()


def test_a_3d_trajectory_holds_both_lateral_axes() -> None:
    """Only x, θy and the beam on x were recorded and plotted for the 3D tasks (issue 42): a row is
    t, then x, θy, d_x, ψ_x, then y, θx, d_y, ψ_y, as the env reports them."""
    env = gym.make("LightSail3D-v0")
    agent = evaluate.BASELINES["lqr"](env.unwrapped.episode_spec)
    steps = evaluate.run_episode(env, agent, 3, trajectory=True)["trajectory"]
    obs, _ = env.reset(seed=3)
    agent.reset()
    action = np.asarray(agent.act(obs), dtype=np.float32)
    state = env.step(action)[4]["state"]
    d_x, d_y, psi_x, psi_y = np.clip(action, -1, 1) * env.unwrapped.episode_spec.action_scale
    np.testing.assert_array_equal(steps[0, 1:], [state["x"], state["theta_y"], d_x, psi_x,
                                                 state["y"], state["theta_x"], d_y, psi_y])
    assert np.abs(steps[:, 5:]).max(axis=0).min() > 0  # the y axis moves: not a column of zeros


def test_the_ceiling_benchmark_pairs_a_trained_model_with_lqg(model: Path, tmp_path: Path) -> None:
    """benchmarks.ceiling takes a model path beside the baselines: its row holds its episodes'
    successes and its paired difference to LQG, which is the difference of the two rates."""
    from benchmarks import ceiling

    out = tmp_path / "ceiling.json"
    ceiling.main(["--env", "LightSail-v0", "--agent", "lqg", "--agent", str(model), "--episodes", "6", "--out", str(out)])
    rows = json.loads(out.read_text())["LightSail-v0"]["agents"]
    learned, lqg = rows[str(model)], rows["lqg"]
    assert len(learned["success"]) == 6 and learned["episodes"] == 6
    assert learned["vs_lqg"]["difference"] == pytest.approx(learned["success_rate"] - lqg["success_rate"])
