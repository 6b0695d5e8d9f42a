"""Smoke tests of train.py: a few hundred steps, the files a run writes, resume, Ctrl-C."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from stable_baselines3 import PPO

ROOT = Path(__file__).resolve().parents[1]
from agents import training as train

FAST = ["--n-envs", "2", "--eval-freq", "256", "--eval-episodes", "2", "--save-freq", "256", "--no-progress-bar"]


def test_train_writes_a_complete_run_and_resume_continues_the_counter(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "512", "--out", str(out), *FAST]) == 0
    for name in ("run.json", "best_model.zip", "best_model_vecnormalize.pkl", "best_model.json",
                 "final_model.zip", "final_model_vecnormalize.pkl", "evaluations.npz",
                 "checkpoints/rl_model_512_steps.zip", "checkpoints/rl_model_vecnormalize_512_steps.pkl"):
        assert (out / name).is_file(), name
    assert list((out / "tb").rglob("events.out.tfevents.*"))
    run = json.loads((out / "run.json").read_text())
    assert run["config"]["seed"] == 0 and run["config"]["hyperparams"]["n_envs"] == 2
    assert {"stable-baselines3", "torch", "gymnasium", "lightsail-gym"} <= set(run["versions"])
    assert "--timesteps 512" in run["command"] and run["sessions"][0]["status"] == "finished"

    assert train.main(["--resume", str(out), "--timesteps", "1024", "--no-progress-bar"]) == 0
    assert PPO.load(out / "final_model.zip").num_timesteps == 1024
    sessions = json.loads((out / "run.json").read_text())["sessions"]
    assert [s["start_timesteps"] for s in sessions] == [0, 512]


def test_off_policy_resume_reloads_the_replay_buffer(tmp_path: Path) -> None:
    out = tmp_path / "sac"
    args = ["--algo", "sac", "--timesteps", "256", "--out", str(out), "--config", str(tmp_path / "sac.yml"), *FAST]
    (tmp_path / "sac.yml").write_text("LightSail-v0:\n  n_timesteps: 256\n  policy: MlpPolicy\n  normalize: true\n"
                                      "  learning_starts: 100\n  policy_kwargs: {net_arch: [16, 16]}\n")
    assert train.main(args) == 0
    assert (out / "checkpoints/rl_model_replay_buffer_256_steps.pkl").is_file()
    assert train.main(["--resume", str(out), "--timesteps", "512", "--no-progress-bar"]) == 0
    assert json.loads((out / "run.json").read_text())["sessions"][-1]["timesteps"] == 512


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_or_sigterm_saves_a_checkpoint_that_resume_continues(tmp_path: Path, signum: int) -> None:
    out = tmp_path / "run"
    # Started with SIGINT ignored, as a shell without job control starts a background job.
    proc = subprocess.Popen([sys.executable, "train.py", "--algo", "ppo", "--timesteps", "10000000",
                             "--out", str(out), *FAST], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    deadline = time.monotonic() + 60
    while not list(out.glob("checkpoints/*.zip")) and time.monotonic() < deadline:
        time.sleep(0.2)
    proc.send_signal(signum)
    output, _ = proc.communicate(timeout=60)
    assert proc.returncode == 130, output
    run = json.loads((out / "run.json").read_text())
    interrupted_at = run["sessions"][0]["timesteps"]
    assert run["sessions"][0]["status"] == "interrupted"
    assert (out / f"checkpoints/rl_model_{interrupted_at}_steps.zip").is_file()
    assert train.main(["--resume", str(out), "--timesteps", str(interrupted_at + 256), "--no-progress-bar"]) == 0
    assert PPO.load(out / "final_model.zip").num_timesteps >= interrupted_at + 256


@pytest.mark.parametrize("argv, message", [
    (["--algo", "ppo", "--env", "CartPole-v1"], "no entry for 'CartPole-v1'"),
    (["--resume", "/nonexistent/run"], "run.json"),
])
def test_bad_configuration_is_a_one_line_error(argv: list[str], message: str, capsys: pytest.CaptureFixture) -> None:
    assert train.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err


@pytest.mark.parametrize("algo", sorted(train.ALGOS))
@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSailDeepDish-v0", "LightSailRealistic-v0"])
def test_shipped_hyperparameters_build_a_model(algo: str, env_id: str) -> None:
    hp = train.load_hyperparams(algo, env_id)
    assert {"n_envs", "n_timesteps", "policy", "normalize"} <= set(hp)
    env = train.make_env(env_id, 1, 0, "dummy", train.normalize_kwargs(hp.pop("normalize")), 0.99, training=True)
    hp.pop("n_envs"), hp.pop("n_timesteps")
    model = train.ALGOS[algo](hp.pop("policy"), env, **train.algo_kwargs(hp, 2))
    assert model.policy is not None


def test_resume_without_a_checkpoint_is_a_one_line_error(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "run.json").write_text(json.dumps({"config": {"hyperparams": {}}}))
    assert train.main(["--resume", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "no checkpoint to resume from" in err and "\n" not in err
