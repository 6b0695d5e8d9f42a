"""The command-line convention of every script (agents/cli.py): a refused argument is one line on
stderr, exit code 2, and nothing written: no file in the working folder, ``runs/latest`` unchanged.

In-process through each script's ``main(argv)`` (parse-time refusals: fast), and once per script
through the real entry point in a subprocess.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from agents import cli, evaluation, grid, training, tuning

ROOT = Path(__file__).resolve().parents[1]
MAINS: dict[str, Callable[[list[str]], int]] = {"train.py": training.main, "evaluate.py": evaluation.main,
                                                "agents.grid": grid.main, "agents.tuning": tuning.main}
REFUSED = {
    "train.py": [[], ["--algo", "nope"], ["--algo", "ppo", "--seed", "-1"], ["--algo", "ppo", "--timesteps", "0"],
                 ["--algo", "ppo", "--n-envs", "0"], ["--algo", "ppo", "--eval-episodes", "x"],
                 ["--algo", "ppo", "--env", "CartPole-v1"], ["--algo", "ppo", "--bogus"],
                 ["--algo", "ppo", "--config", "missing.yml"], ["--algo", "ppo", "--config", "list.yml"],
                 ["--algo", "ppo", "--out", "file/run"], ["--algo", "ppo", "--out", "runs/old"],
                 ["--resume", "missing"]],
    "evaluate.py": [[], ["--agent", "nope"], ["--agent", "lqr", "--seed", "-1"], ["--agent", "lqr", "--episodes", "0"],
                    ["--agent", "lqr", "--env", "CartPole-v1"], ["--agent", "lqr", "--out", "file/report"],
                    ["--agent", "lqr", "--agent", "lqr"], ["--agent", "runs/latest/best_model.zip"],
                    ["--agent", "lqr", "--out", "reports/old"], ["--agent", "lqr", "--out", "runs"]],
    "agents.grid": [[], ["bogus"], ["status"], ["render"], ["run", "--seeds", "-1"], ["run", "--default-seeds", "x"],
                    ["run", "--grace", "1", "--heartbeat", "30"], ["run", "--envs", "CartPole-v1"],
                    ["run", "--algos", "ppo", "ppo"], ["render", "--readme", "missing.md"],
                    ["render", "--readme", "file"], ["status", "--storage", "bogus://x"],
                    ["run", "--storage", "sqlite:///file/grid.db"], ["run", "--heartbeat", "0"]],
    "agents.tuning": [[], ["--algo", "nope"], ["--algo", "ppo", "--seed", "-1"], ["--algo", "ppo", "--trials", "0"],
                      ["--algo", "ppo", "--env", "CartPole-v1"], ["--algo", "ppo", "--storage", "bogus://x"],
                      ["--algo", "ppo", "--runs-dir", "file/tuning"]],
}


@pytest.fixture
def workdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A working folder with an earlier run that ``runs/latest`` points at, an earlier report, and
    a regular file."""
    (tmp_path / "runs/old").mkdir(parents=True)
    (tmp_path / "runs/old/run.json").write_text("{}")
    (tmp_path / "reports/old").mkdir(parents=True)
    (tmp_path / "reports/old/report.json").write_text("{}")
    (tmp_path / "runs/latest").symlink_to("old")
    (tmp_path / "file").write_text("not a folder\n")
    (tmp_path / "list.yml").write_text("LightSail-v0:\n  - n_timesteps: 100\n")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def snapshot(folder: Path) -> dict[str, str]:
    """Every path under ``folder`` with its link target or size: what a refusal must not change."""
    return {str(p.relative_to(folder)): os.readlink(p) if p.is_symlink() else str(p.stat().st_size)
            for p in sorted(folder.rglob("*"))}


def assert_refused(code: int | None, out: str, err: str) -> None:
    err = err.strip()
    assert code == 2, (code, err)
    assert err.startswith("error: ") and "\n" not in err and "Traceback" not in err, err
    assert out == ""


@pytest.mark.parametrize("script, argv", [(script, argv) for script, argvs in REFUSED.items() for argv in argvs],
                         ids=lambda value: " ".join(value) if isinstance(value, list) else value)
def test_a_refused_argument_is_one_line_exit_2_and_writes_nothing(
        script: str, argv: list[str], workdir: Path, capsys: pytest.CaptureFixture) -> None:
    before = snapshot(workdir)
    try:
        code = MAINS[script](argv)
    except SystemExit as stop:  # argparse's own exit would be a convention broken: report it as such
        code = stop.code
    captured = capsys.readouterr()
    assert_refused(code, captured.out, captured.err)
    assert snapshot(workdir) == before


# A script file and a module (each takes seconds to import torch and SB3: two, not four).
@pytest.mark.parametrize("command", [["train.py", "--algo", "ppo", "--seed", "-1"], ["-m", "agents.grid", "status"]],
                         ids=lambda command: command[command[0] == "-m"])
def test_the_entry_points_keep_the_convention(command: list[str], workdir: Path) -> None:
    script = [str(ROOT / command[0])] if command[0].endswith(".py") else command[:2]
    rest = command[1:] if command[0].endswith(".py") else command[2:]
    before = snapshot(workdir)
    done = subprocess.run([sys.executable, *script, *rest], cwd=workdir, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert_refused(done.returncode, done.stdout, done.stderr)
    assert snapshot(workdir) == before


@pytest.mark.parametrize("script", MAINS)
def test_help_is_plain_text_with_each_default_once(script: str, capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as stop:
        MAINS[script](["--help"])
    assert stop.value.code == 0
    text = capsys.readouterr().out
    assert "``" not in text  # reStructuredText markup of the docstring
    options = re.split(r"\n  (?=-)", text.split("options:", 1)[1])
    for option in options:
        assert option.count("(default:") <= 1, option
        assert "(default: None)" not in option and "(default: [])" not in option, option
    # The whole docstring, not its first line only (which stopped mid-sentence).
    module = {"train.py": training, "evaluate.py": evaluation, "agents.grid": grid, "agents.tuning": tuning}[script]
    last_line = [line for line in module.__doc__.replace("``", "").splitlines() if line.strip()][-1]
    assert " ".join(last_line.split()) in " ".join(text.split())


def test_a_readme_section_is_replaced_whole_or_not_at_all(tmp_path, monkeypatch) -> None:
    """The README is written beside itself and renamed over: its permissions stay, nothing is left
    behind, and an interrupted rename leaves the old text as it was."""
    import os
    import stat

    readme = tmp_path / "README.md"
    readme.write_text("intro\n<!-- part:start -->\nold\n<!-- part:end -->\nend\n")
    readme.chmod(0o644)
    cli.replace_readme_section(readme, "part", "new")
    assert readme.read_text() == "intro\n<!-- part:start -->\nnew\n<!-- part:end -->\nend\n"
    assert stat.S_IMODE(readme.stat().st_mode) == 0o644 and os.listdir(tmp_path) == ["README.md"]

    def interrupted(source, target):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        cli.replace_readme_section(readme, "part", "newer")
    assert "new\n" in readme.read_text() and "newer" not in readme.read_text()
    assert os.listdir(tmp_path) == ["README.md"]
