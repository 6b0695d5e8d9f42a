"""The benchmark grid end to end at tiny budgets: SQLite with one worker, and two concurrent
workers on SQLite and on a real PostgreSQL server started on loopback, one of them killed
mid-cell."""

from __future__ import annotations

import glob
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import optuna
import pytest
from optuna.trial import TrialState

from agents import grid, training

ROOT = Path(__file__).resolve().parents[1]
TINY = ["--timesteps", "256", "--eval-freq", "128", "--eval-episodes", "2", "--save-freq", "128"]


def load(storage: str, study: str = grid.DEFAULT_STUDY) -> optuna.Study:
    return optuna.load_study(storage=grid.storage_url(storage), study_name=study)


def test_sqlite_grid_runs_resumes_and_renders(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    argv = ["--envs", "LightSail-v0", "--algos", "ppo", "--seeds", "0", "1", "--default-seeds", "0", *TINY]
    assert grid.main(["run", *argv, "--max-cells", "4"]) == 0  # stop part-way, then resume
    assert grid.main(["status"]) == 0
    assert "4 complete, 2 waiting" in capsys.readouterr().out
    assert grid.main(["run", *argv]) == 0
    assert grid.main(["run", *argv]) == 0  # nothing left: no cell runs twice
    study = load(grid.DEFAULT_STORAGE)
    trials = study.get_trials()
    assert len(trials) == 6 and all(t.state == TrialState.COMPLETE for t in trials)
    cells = {t.user_attrs["cell"] for t in trials}
    assert cells == {"LightSail-v0-passive-none-0", "LightSail-v0-lqr-none-0", "LightSail-v0-lqg-none-0",
                     "LightSail-v0-ppo-tuned-0", "LightSail-v0-ppo-tuned-1", "LightSail-v0-ppo-default-0"}
    default = next(t for t in trials if t.user_attrs["cell"] == "LightSail-v0-ppo-default-0")
    assert default.user_attrs["hyperparams"] == {"n_timesteps": 256, "policy": "MlpPolicy"}
    for trial in trials:
        summary = trial.user_attrs["summary"]
        assert summary["episodes"] == grid.EPISODES and trial.value == summary["success_rate"]
        assert {"stable-baselines3", "torch", "lightsail-gym"} <= set(trial.user_attrs["versions"])
        if "run_dir" in trial.user_attrs and trial.params["agent"] == "ppo":  # its learning curve, kept
            history = training.selection_history(Path(trial.user_attrs["run_dir"]))
            assert len(history) >= 2 and sorted(trial.intermediate_values.items()) == history

    readme = tmp_path / "README.md"
    readme.write_text(f"before\n{grid.README_START}\nold\n{grid.README_END}\nafter\n")
    capsys.readouterr()
    assert grid.main(["render", "--readme", str(readme)]) == 0
    table = capsys.readouterr().out.strip()
    assert readme.read_text() == f"before\n{grid.README_START}\n{table}\n{grid.README_END}\nafter\n"
    rows = {tuple(cell.strip() for cell in line.split("|")[2:4]): line for line in table.splitlines()[2:]}
    tuned = [t for t in trials if t.params["hyperparameters"] == "tuned"]
    mean = 100 * sum(t.value for t in tuned) / 2
    assert f"| 2/2 | {mean:.1f} %" in rows[("ppo", "tuned")]
    lqr = next(t for t in trials if t.params["agent"] == "lqr").user_attrs["summary"]
    assert f"| 1/1 | {100 * lqr['success_rate']:.1f} % |" in rows[("lqr", "–")]

    # After an agent's code changed: its cells run again; a learner's only replays its episodes.
    assert grid.main(["redo", "--envs", "LightSail-v0", "--agents", "lqg", "ppo"]) == 0
    assert grid.main(["status"]) == 0
    assert "6 cells, 2 complete, 4 waiting" in capsys.readouterr().out
    assert grid.main(["run", *argv]) == 0
    redone = [t for t in load(grid.DEFAULT_STORAGE).get_trials() if t.number >= 6]
    assert len(redone) == 4 and all(t.state == TrialState.COMPLETE for t in redone)
    first = {t.user_attrs["cell"]: t for t in trials}
    for trial in redone:
        if trial.params["agent"] == "ppo":  # not trained again
            before = first[trial.user_attrs["cell"]].user_attrs
            assert (trial.user_attrs["timesteps"], trial.user_attrs["wall_time_s"]) == (before["timesteps"],
                                                                                      before["wall_time_s"])
    capsys.readouterr()
    assert grid.main(["render"]) == 0
    assert capsys.readouterr().out.strip() == table  # the same code plays the same episodes


def test_the_ceiling_and_the_paired_comparison_in_the_table(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                            capsys: pytest.CaptureFixture) -> None:
    """``--classical`` adds the bounds (lqg-mm only where it applies, the 3D tasks); every row is paired
    with LQG on the same episodes (its interval from the stored outcomes) and measured below the ceiling."""
    monkeypatch.chdir(tmp_path)
    argv = ["--study", "ceiling", "--envs", "LightSail-v0", "--algos", "ppo", "--seeds", "0", "--default-seeds",
            "--classical", "passive", "lqg", "lqg-mm", "lqr-oracle", *TINY]
    assert grid.main(["run", *argv]) == 0
    trials = load(grid.DEFAULT_STORAGE, "ceiling").get_trials()
    assert {t.user_attrs["cell"] for t in trials} == {"LightSail-v0-passive-none-0", "LightSail-v0-lqg-none-0",
                                                      "LightSail-v0-lqr-oracle-none-0", "LightSail-v0-ppo-tuned-0"}
    outcome = {t.params["agent"]: t.user_attrs["summary"] for t in trials}
    capsys.readouterr()
    assert grid.main(["render", "--study", "ceiling"]) == 0
    rows = {line.split("|")[2].strip(): line for line in capsys.readouterr().out.strip().splitlines()[2:]}
    assert set(rows) == {"passive", "lqg", "ppo", "lqr-oracle (a bound)"}
    passive = np.array(outcome["passive"]["successes"], float) - np.array(outcome["lqg"]["successes"], float)
    assert f"| {100 * passive.mean():+.1f} pts (" in rows["passive"]
    ceiling = 100 * outcome["lqr-oracle"]["success_rate"]
    assert f"| {ceiling - 100 * outcome['passive']['success_rate']:.1f} pts |" in rows["passive"]
    assert rows["lqg"].split("|")[6].strip() == "–"  # the reference itself


def test_a_grid_of_the_recurrent_learner_keeps_the_older_grids_choices(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                          capsys: pytest.CaptureFixture) -> None:
    """``recurrent_ppo`` runs when asked for. A grid that asks for no learner beyond PPO, SAC and TD3
    keeps their three choices (Optuna refuses a parameter whose choices change within a study, so
    the grids made before recurrent_ppo existed still resume)."""
    monkeypatch.chdir(tmp_path)
    argv = ["--study", "memory", "--envs", "LightSail-v0", "--algos", "recurrent_ppo", "--seeds", "0",
            "--default-seeds", "--classical", "lqg", *TINY]
    assert grid.main(["run", *argv]) == 0
    study = load(grid.DEFAULT_STORAGE, "memory")
    assert {t.user_attrs["cell"] for t in study.get_trials()} == {"LightSail-v0-lqg-none-0",
                                                                  "LightSail-v0-recurrent_ppo-tuned-0"}
    assert all(t.state == TrialState.COMPLETE for t in study.get_trials())
    assert grid.learner_choices(study.user_attrs["settings"]) == tuple(sorted(grid.ALGOS))
    capsys.readouterr()
    assert grid.main(["render", "--study", "memory"]) == 0
    assert "| recurrent_ppo |" in capsys.readouterr().out
    assert grid.learner_choices({"algos": ["ppo"]}) == ("ppo", "sac", "td3")


def test_a_grid_made_with_other_settings_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    assert grid.main(["run", "--envs", "LightSail-v0", "--algos", "ppo", "--seeds", "0", "--default-seeds",
                      "--max-cells", "1", *TINY]) == 0
    capsys.readouterr()
    assert grid.main(["run", "--envs", "LightSail-v0", *TINY]) == 2
    err = capsys.readouterr().err.strip()
    assert "use another --study" in err and "\n" not in err


# ---------------------------------------------------------------------- two workers
def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(scope="module")
def postgresql() -> Iterator[str]:
    """A throw-away PostgreSQL server on loopback (Debian's packages; .ci/run installs them)."""
    found = shutil.which("initdb") or next(iter(sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))), None)
    if found is None:
        pytest.skip("PostgreSQL is not installed (apt-get install postgresql): the multi-machine test needs a server")
    bin_dir = Path(found).resolve().parent
    data = Path(tempfile.mkdtemp(prefix="grid-postgresql-"))  # pytest's own tmp dirs are closed to other users
    as_user: list[str] = []
    if os.geteuid() == 0:  # the server refuses to run as root
        as_user = ["runuser", "-u", "postgres", "--"]
        shutil.chown(data, "postgres")
    port = free_port()
    subprocess.run([*as_user, str(bin_dir / "initdb"), "-D", str(data / "db"), "-U", "grid", "--auth=trust"],
                   check=True, capture_output=True)
    subprocess.run([*as_user, str(bin_dir / "pg_ctl"), "-D", str(data / "db"), "-l", str(data / "log"), "-w", "start",
                    "-o", f"-c listen_addresses=127.0.0.1 -p {port} -k {data}"], check=True, capture_output=True)
    try:
        subprocess.run([*as_user, str(bin_dir / "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", "grid", "grid"],
                       check=True, capture_output=True)
        yield f"postgresql://grid@127.0.0.1:{port}/grid"
    finally:
        subprocess.run([*as_user, str(bin_dir / "pg_ctl"), "-D", str(data / "db"), "-m", "immediate", "stop"],
                       capture_output=True)
        shutil.rmtree(data, ignore_errors=True)


def start_worker(storage: str, cwd: Path, log: Path, argv: list[str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "agents.grid", "run", "--storage", storage, *argv], cwd=cwd,
                            env={**os.environ, "PYTHONPATH": str(ROOT)}, stdout=log.open("w"), stderr=subprocess.STDOUT)


#: The learner cells' budget in the two-worker test (whole rollouts of 8 envs x 256 steps).
BUDGET_STEPS = 12288


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_two_workers_run_every_cell_once_and_finish_a_killed_workers_cell(backend: str, tmp_path: Path,
                                                                          request: pytest.FixtureRequest) -> None:
    storage = f"sqlite:///{tmp_path}/grid.db" if backend == "sqlite" else request.getfixturevalue("postgresql")
    study_name = f"two-workers-{backend}-{os.getpid()}"
    argv = ["--study", study_name, "--runs-dir", str(tmp_path / "runs"), "--envs", "LightSail-v0", "--algos", "ppo",
            "--seeds", "0", "1", "2", "--default-seeds", "--timesteps", str(BUDGET_STEPS), "--eval-freq", "0", "--save-freq", "2048",
            "--heartbeat", "1", "--grace", "3"]
    workers = [start_worker(storage, tmp_path, tmp_path / f"worker{i}.log", argv) for i in range(2)]
    # Kill whichever worker is first seen in a learner cell that has a complete checkpoint (its
    # statistics are written last; a checkpoint cut short is skipped, see test_train.py).
    deadline, victim = time.monotonic() + 120, None
    while victim is None and time.monotonic() < deadline:
        for i, worker in enumerate(workers):
            started = re.findall(r"(\S+-ppo-tuned-\d): started .* -> (\S+)", (tmp_path / f"worker{i}.log").read_text())
            # A checkpoint two rollouts short of the budget: the cell is still training when the kill
            # lands (the compiled env trains a cell in seconds: a worker killed after its last
            # checkpoint had completed it, and once in CI one killed a rollout short had finished).
            saved = [int(p.stem.split("_")[-2]) for p in Path(started[-1][1]).glob(
                "checkpoints/rl_model_vecnormalize_*_steps.pkl")] if started else []
            # At least two rollouts in: a checkpoint at a rollout's last step holds the weights from
            # before its update, and the cell resumes from the rollout's start (training.resume_point).
            if saved and 2 * 2048 <= max(saved) <= BUDGET_STEPS - 2 * 2048:
                victim, (killed_worker, survivor) = started[-1][0], (workers[i], workers[1 - i])
                killed_worker.send_signal(signal.SIGKILL)
                break
        time.sleep(0.1)
    assert victim is not None, "no worker reached a learner cell"
    assert survivor.wait(timeout=300) == 0, [(tmp_path / f"worker{i}.log").read_text() for i in range(2)]
    killed_worker.wait()

    trials = load(storage, study_name).get_trials()
    complete = Counter(t.user_attrs["cell"] for t in trials if t.state == TrialState.COMPLETE)
    assert complete == Counter({"LightSail-v0-passive-none-0": 1, "LightSail-v0-lqr-none-0": 1,
                                "LightSail-v0-lqg-none-0": 1, "LightSail-v0-ppo-tuned-0": 1,
                                "LightSail-v0-ppo-tuned-1": 1, "LightSail-v0-ppo-tuned-2": 1})
    killed = [t for t in trials if t.user_attrs.get("cell") == victim and t.state == TrialState.FAIL]
    assert len(killed) == 1
    finisher = next(t for t in trials if t.user_attrs.get("cell") == victim and t.state == TrialState.COMPLETE)
    assert finisher.user_attrs["worker"].endswith(f":{survivor.pid}")
    sessions = grid.training.read_run(Path(finisher.user_attrs["run_dir"]))["sessions"]
    assert sessions[0]["status"] == "running"  # the killed worker's session never ended
    assert sessions[-1]["start_timesteps"] > 0 and sessions[-1]["timesteps"] >= 12288  # resumed, not restarted


# ---------------------------------------------------------------------- refusals
def _snapshot(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@pytest.mark.parametrize("argv, message", [
    (["run", "--grace", "1", "--heartbeat", "30"], "--grace: must be at least 2 × --heartbeat (30 s), got 1"),
    (["run", "--envs", "LightSail-v0", "LightSail-v0"], "--envs: LightSail-v0 given more than once"),
    (["run", "--algos", "ppo", "ppo"], "--algos: ppo given more than once"),
    (["run", "--seeds", "0", "0"], "--seeds: 0 given more than once"),
    (["run", "--seeds", "-1"], "--seeds: must be >= 0, got -1"),
    (["run", "--default-seeds", "-2"], "--default-seeds: must be >= 0, got -2"),
    (["redo", "--agents", "lqr", "lqr"], "--agents: lqr given more than once"),
    (["render", "--readme", "missing.md"], "--readme missing.md: cannot read it"),
    (["render", "--readme", "plain.md"], "--readme plain.md: no <!-- grid-table:start -->"),
    (["status"], "no grid 'planar' yet (runs/grid.db does not exist): python -m agents.grid run --study planar "
                 "creates it"),
    (["status", "--study", "3d"],
     "no grid '3d' yet (runs/grid.db does not exist): python -m agents.grid run --study 3d"),
    (["render"], "no grid 'planar' yet"),
    (["status", "--storage", "bogus://x"], "--storage bogus://x: cannot open it (NoSuchModuleError"),
    (["status", "--storage", "sqlite:///damaged.db"], "cannot open it (DatabaseError: file is not a database)"),
    (["run", "--storage", "sqlite:///damaged.db"], "cannot open it (DatabaseError: file is not a database)"),
    (["run", "--storage", "sqlite:///plain.md/grid.db"], "plain.md is not a directory"),
    (["export"], "export needs --file"),
    (["import", "--file", "missing.json"], "--file missing.json: No such file or directory"),
    (["import", "--file", "plain.md"], "--file plain.md: Expecting value"),
    (["export", "--file", "plain.md/grid.json"], "plain.md is not a directory"),
])
def test_refused_arguments_are_one_line_and_write_nothing(argv: list[str], message: str, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch,
                                                          capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "plain.md").write_text("no markers\n")
    (tmp_path / "damaged.db").write_bytes(b"not a database, " * 100)
    before = _snapshot(tmp_path)
    assert grid.main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err and captured.out == ""
    assert _snapshot(tmp_path) == before


def test_a_study_that_does_not_exist_says_how_to_make_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs").mkdir()
    optuna.create_study(storage=grid.DEFAULT_STORAGE, study_name="other")
    assert grid.main(["status", "--study", "planar"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--study planar: no such grid in the storage (it has ['other'])" in err
    assert "python -m agents.grid run --study planar creates it" in err and "\n" not in err


def test_a_kept_grid_is_a_new_grid_elsewhere_and_runs_on(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture) -> None:
    """A fresh checkout has no runs/: the grid's finished cells, exported with the code, become a
    new grid in another storage; its missing cells are queued and run, the imported ones never."""
    monkeypatch.chdir(tmp_path)
    argv = ["--envs", "LightSail-v0", "--algos", "ppo", "--seeds", "0", "--default-seeds", *TINY]
    assert grid.main(["run", *argv, "--max-cells", "2"]) == 0
    assert grid.main(["export", "--file", "kept/planar.json"]) == 0
    elsewhere = f"sqlite:///{tmp_path}/elsewhere.db"
    assert grid.main(["import", "--file", "kept/planar.json", "--storage", elsewhere]) == 0
    assert "2 finished cells imported, 2 queued" in capsys.readouterr().out
    assert grid.main(["import", "--file", "kept/planar.json", "--storage", elsewhere]) == 2  # not twice
    assert "already has a grid 'planar'" in capsys.readouterr().err
    assert grid.main(["status", "--storage", elsewhere]) == 0
    assert "4 cells, 2 complete, 2 waiting" in capsys.readouterr().out
    assert grid.main(["run", *argv, "--storage", elsewhere]) == 0
    before = {t.user_attrs["cell"]: t for t in load(grid.DEFAULT_STORAGE).get_trials(states=(TrialState.COMPLETE,))}
    after = load(elsewhere).get_trials()
    assert len(after) == 4 and all(t.state == TrialState.COMPLETE for t in after)
    for trial in after[:2]:  # the imported cells, as they were
        assert trial.user_attrs["summary"] == before[trial.user_attrs["cell"]].user_attrs["summary"]
        assert trial.params == before[trial.user_attrs["cell"]].params
    assert grid.main(["render", "--storage", elsewhere]) == 0 and "| lqr |" in capsys.readouterr().out


# ---------------------------------------------------------------------- a cell taken from a live worker
def test_a_cell_taken_from_its_live_worker_is_recorded_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                           capsys: pytest.CaptureFixture) -> None:
    """Its trial failed as stale (heartbeats later than --grace) while the worker ran it: the
    worker exited with "Trial#… has already finished". Now it leaves the cell to the new trial."""
    monkeypatch.chdir(tmp_path)
    taken: list[int] = []

    def run_cell(cell: grid.Cell, trial: optuna.Trial, run_dir: Path, settings: dict) -> dict:
        if not taken:  # what fail_stale_trials in another worker does to a trial it finds stale
            taken.append(trial.number)
            storage = trial.study._storage
            storage.set_trial_state_values(trial._trial_id, TrialState.FAIL)
            storage.get_heartbeat_stale_trial_callback()(trial.study, storage.get_trial(trial._trial_id))
        return {"summary": {"success_rate": 1.0, "terminal_pointing_rad": {"median": None}}}

    monkeypatch.setattr(grid, "run_cell", run_cell)
    assert grid.main(["run", "--envs", "LightSail-v0", "--algos", "ppo", "--seeds", "0", "--default-seeds",
                      *TINY]) == 0
    out = capsys.readouterr().out
    assert "was handed to another worker" in out and "median pointing diverged\n" in out
    trials = load(grid.DEFAULT_STORAGE).get_trials()
    complete = Counter(t.user_attrs["cell"] for t in trials if t.state == TrialState.COMPLETE)
    assert set(complete.values()) == {1} and len(complete) == 4
    assert trials[taken[0]].state == TrialState.FAIL and "summary" not in trials[taken[0]].user_attrs


def test_a_second_trial_of_a_running_cell_waits_for_its_lock(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    import threading

    run_dir, order = tmp_path / "study" / "cell", []
    with grid.cell_lock(run_dir, "cell"):
        def take() -> None:
            with grid.cell_lock(run_dir, "cell"):
                order.append("second")
        second = threading.Thread(target=take)
        second.start()
        second.join(timeout=1)
        assert second.is_alive()  # waiting
        order.append("first done")
    second.join(timeout=10)
    assert order == ["first done", "second"]
    assert "another worker still runs this cell; waiting" in capsys.readouterr().out


def test_the_table_has_a_row_place_for_every_agent():
    """An agent missing from ROW_ORDER would be left out of the table without a word."""
    assert sorted(grid.ROW_ORDER) == sorted(grid.AGENTS)


def test_a_file_without_grid_settings_is_refused_before_the_storage_is_made(tmp_path: Path,
                                                                           capsys: pytest.CaptureFixture) -> None:
    kept_study = tmp_path / "tuning.json"
    kept_study.write_text('{"study": "planar", "user_attrs": {}, "trials": []}')
    assert grid.main(["import", "--file", str(kept_study), "--storage", f"sqlite:///{tmp_path}/grid.db"]) == 2
    assert "no grid settings" in capsys.readouterr().err and not (tmp_path / "grid.db").exists()
