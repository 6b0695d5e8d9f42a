"""Smoke tests of train.py: a few hundred steps, the files a run writes, resume, Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from stable_baselines3 import PPO

ROOT = Path(__file__).resolve().parents[1]
from agents import training as train
from sail_env.tasks import TASKS

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
    # The evaluation history spans both sessions (the resumed EvalCallback used to start it afresh).
    with np.load(out / "evaluations.npz") as log:
        assert log["timesteps"].tolist() == [256, 512, 768, 1024] and log["successes"].shape == (4, 2)


def test_off_policy_resume_reloads_the_replay_buffer(tmp_path: Path) -> None:
    out = tmp_path / "sac"
    args = ["--algo", "sac", "--timesteps", "256", "--out", str(out), "--config", str(tmp_path / "sac.yml"), *FAST]
    (tmp_path / "sac.yml").write_text("LightSail-v0:\n  n_timesteps: 256\n  policy: MlpPolicy\n  normalize: true\n"
                                      "  learning_starts: 100\n  policy_kwargs: {net_arch: [16, 16]}\n")
    assert train.main(args) == 0
    assert (out / "checkpoints/rl_model_replay_buffer_256_steps.pkl").is_file()
    assert train.main(["--resume", str(out), "--timesteps", "512", "--no-progress-bar"]) == 0
    assert json.loads((out / "run.json").read_text())["sessions"][-1]["timesteps"] == 512


def test_a_frame_stacked_run_trains_resumes_its_statistics_and_is_evaluated(tmp_path: Path) -> None:
    """``frame_stack: 3``: the training and selection envs stack three normalised observations; a
    resumed run continues the checkpoint's VecNormalize statistics under the stack; evaluate.py
    plays the final model and a checkpoint."""
    import numpy as np
    from stable_baselines3.common.vec_env import VecFrameStack, VecNormalize

    from agents import evaluation
    from agents.sb3 import load_normalizer

    (tmp_path / "fs.yml").write_text("LightSail-v0:\n  n_timesteps: 256\n  policy: MlpPolicy\n  normalize: true\n"
                                     "  frame_stack: 3\n  n_steps: 64\n  batch_size: 64\n"
                                     "  policy_kwargs: {net_arch: [16, 16]}\n")
    out = tmp_path / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "256", "--config", str(tmp_path / "fs.yml"),
                       "--out", str(out), *FAST]) == 0
    assert PPO.load(out / "checkpoints/rl_model_256_steps.zip").observation_space.shape == (15,)
    assert (out / "best_model.zip").is_file()  # selected on the stacked evaluation env

    config = train.read_run(out)["config"]
    config["hyperparams"]["n_timesteps"] = 512
    saved = load_normalizer(out / "checkpoints/rl_model_vecnormalize_256_steps.pkl", (5,))
    setup = train.prepare(config, out)
    try:
        assert isinstance(setup.train_env, VecFrameStack) and isinstance(setup.eval_env, VecFrameStack)
        normalizer = setup.train_env.venv
        assert isinstance(normalizer, VecNormalize) and not isinstance(normalizer.venv, VecNormalize)
        assert setup.model.get_vec_normalize_env() is normalizer and normalizer.training
        np.testing.assert_array_equal(normalizer.obs_rms.mean, saved.obs_rms.mean)
        assert normalizer.obs_rms.count == saved.obs_rms.count > 256
    finally:
        setup.close()

    assert train.main(["--resume", str(out), "--timesteps", "512", "--no-progress-bar"]) == 0
    assert PPO.load(out / "final_model.zip").num_timesteps == 512
    report = tmp_path / "report"
    assert evaluation.main(["--agent", str(out / "final_model.zip"), "--agent",
                            str(out / "checkpoints/rl_model_512_steps.zip"), "--episodes", "2",
                            "--out", str(report), "--no-progress-bar"]) == 0
    assert len(json.loads((report / "report.json").read_text())["agents"]) == 2


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


def exit_code(argv: list[str]) -> int:
    """train.main's exit code, whether it returns it or argparse exits with it."""
    try:
        return train.main(argv)
    except SystemExit as stop:
        return int(stop.code)


@pytest.mark.parametrize("argv, message", [
    (["--algo", "ppo", "--env", "CartPole-v1"], "invalid choice: 'CartPole-v1'"),
    (["--resume", "/nonexistent/run"], "run.json"),
    (["--algo", "ppo", "--timesteps", "0"], "--timesteps: must be >= 1"),
    (["--algo", "ppo", "--eval-episodes", "0"], "--eval-episodes: must be >= 1"),
    (["--algo", "ppo", "--seed", "-1"], "--seed: must be >= 0"),
    (["--algo", "ppo", "--n-envs", "two"], "--n-envs"),
])
def test_bad_arguments_are_a_one_line_error(argv: list[str], message: str, capsys: pytest.CaptureFixture,
                                            tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert exit_code(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("entry, message", [
    ("  policy: MlpPolicy\n", "n_timesteps is missing"),
    ("  n_timesteps: 0\n", "n_timesteps must be a whole number >= 1"),
    ("  n_timesteps: 100\n  learning_rat: 0.1\n", "ppo has no hyperparameter learning_rat"),
    ("  n_timesteps: 100\n  policy_kwargs: \"dict(net_arch=[8], activation_fn=nn.Nope)\"\n", "Nope"),
    ("  n_timesteps: 100\n  noise_type: pink\n", "noise_type"),
    ("  n_timesteps: 100\n  n_steps: 0\n", "n_steps must be a whole number >= 1, got 0"),
    ("  n_timesteps: 100\n  n_steps: 1\n  n_envs: 1\n", "n_steps × n_envs (PPO's rollout) must be >= 2, got 1 × 1"),
    ("  n_timesteps: 100\n  batch_size: -3\n", "batch_size must be a whole number >= 2, got -3"),
    ("  n_timesteps: 100\n  n_epochs: 0\n", "n_epochs must be a whole number >= 1, got 0"),
    ("  n_timesteps: 100\n  n_epochs: 2.5\n", "n_epochs must be a whole number >= 1, got 2.5"),
    ("  n_timesteps: 100\n  policy: NopePolicy\n", "policy must be MlpPolicy"),
    ("  - n_timesteps: 100\n", "the entry must be a mapping of hyperparameters"),
    ("  n_timesteps: 100\n  frame_stack: 0\n", "frame_stack must be a whole number >= 1, got 0"),
    ("  n_timesteps: 100\n  frame_stack: 2.5\n", "frame_stack must be a whole number >= 1, got 2.5"),
    ("  n_timesteps: 100\n  frame_stack: true\n", "frame_stack must be a whole number >= 1, got True"),
    ("  n_timesteps: 100\n  frame_stack: four\n", "frame_stack must be a whole number >= 1, got 'four'"),
    # Real numbers out of SB3's ranges trained on (gamma 1.5: overflow warnings, exit 0).
    ("  n_timesteps: 100\n  gamma: 1.5\n", "gamma must be a number in [0, 1], got 1.5"),
    ("  n_timesteps: 100\n  gae_lambda: -0.1\n", "gae_lambda must be a number in [0, 1], got -0.1"),
    ("  n_timesteps: 100\n  learning_rate: 0.0\n", "learning_rate must be a number in (0, inf), got 0.0"),
    ("  n_timesteps: 100\n  learning_rate: lin_-1.0e-3\n",
     "learning_rate must be a number in (0, inf), got 'lin_-1.0e-3'"),
    ("  n_timesteps: 100\n  ent_coef: -0.01\n", "ent_coef must be a number in [0, inf), got -0.01"),
    ("  n_timesteps: 100\n  max_grad_norm: 0\n", "max_grad_norm must be a number in (0, inf), got 0"),
    ("  n_timesteps: 100\n  gamma: .nan\n", "gamma must be a number in [0, 1], got nan"),
    ("  n_timesteps: 100\n  vf_coef: .inf\n", "vf_coef must be a number in [0, inf), got inf"),
    # Passes the checks, refused by SB3's constructor: the model is built before any folder is made.
    ("  n_timesteps: 100\n  clip_range_vf: -1.0\n", "ppo does not accept these hyperparameters"),
])
def test_a_bad_hyperparameter_entry_is_a_one_line_error_and_writes_nothing(
        entry: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.yml").write_text("LightSail-v0:\n" + entry)
    assert train.main(["--algo", "ppo", "--config", "bad.yml", "--no-progress-bar"]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "bad.yml [LightSail-v0]" in err and "\n" not in err
    assert not (tmp_path / "runs").exists()


@pytest.mark.parametrize("algo", ["sac", "td3"])
def test_an_off_policy_run_refuses_a_normalised_stack(algo: str, tmp_path: Path, capsys: pytest.CaptureFixture,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """SB3's replay buffer stores VecNormalize's original observations, which VecFrameStack above it has
    not stacked: the first stored transition failed on the shapes, after the model was built."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "stack.yml").write_text("LightSail-v0:\n  n_timesteps: 300\n  learning_starts: 10\n"
                                        "  normalize: true\n  frame_stack: 2\n")
    assert train.main(["--algo", algo, "--config", "stack.yml", "--no-progress-bar"]) == 2
    err = capsys.readouterr().err.strip()
    assert "frame_stack > 1 with normalize needs an on-policy algorithm" in err and "\n" not in err
    assert not (tmp_path / "runs").exists()
    (tmp_path / "stack.yml").write_text("LightSail-v0:\n  n_timesteps: 300\n  learning_starts: 10\n"
                                        "  normalize: false\n  frame_stack: 2\n")
    assert train.main(["--algo", algo, "--config", "stack.yml", "--eval-freq", "0", "--no-progress-bar"]) == 0


def test_a_refused_configuration_leaves_runs_latest_alone(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs/old").mkdir(parents=True)
    (tmp_path / "runs/latest").symlink_to("old")
    (tmp_path / "bad.yml").write_text("LightSail-v0:\n  n_timesteps: 100\n  clip_range_vf: -1.0\n")
    assert train.main(["--algo", "ppo", "--config", "bad.yml", "--no-progress-bar"]) == 2
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == ["latest", "old"]
    assert os.readlink(tmp_path / "runs/latest") == "old"
    assert capsys.readouterr().out == ""


def test_runs_started_at_once_get_a_folder_each(tmp_path: Path) -> None:
    """Two identical train.py commands at once shared runs/<env>-<algo>-<seed>: the second looked
    for a run.json before the first had written one."""
    from concurrent.futures import ThreadPoolExecutor

    (tmp_path / "LightSail-v0-ppo-0").mkdir()  # just made by a run that has not written run.json yet
    with ThreadPoolExecutor(4) as pool:
        made = list(pool.map(lambda _: train.new_run_dir("LightSail-v0", "ppo", 0, tmp_path), range(8)))
    assert len(set(made)) == 8 and tmp_path / "LightSail-v0-ppo-0" not in made
    assert all(path.is_dir() and not any(path.iterdir()) for path in made)


def test_the_header_names_the_folder_the_run_got(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs/LightSail-v0-ppo-0").mkdir(parents=True)
    assert train.main(["--algo", "ppo", "--timesteps", "64", *FAST, "--eval-freq", "0", "--n-envs", "1",
                       "--config", str(ROOT / "agents/hyperparams/ppo.yml")]) == 0
    assert capsys.readouterr().out.splitlines()[0].endswith("-> runs/LightSail-v0-ppo-0_2")
    assert os.readlink(tmp_path / "runs/latest") == "LightSail-v0-ppo-0_2"
    assert not any((tmp_path / "runs/LightSail-v0-ppo-0").iterdir())


def _refused(argv: list[str], capsys: pytest.CaptureFixture) -> str:
    assert train.main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert captured.out == "" and err.startswith("error: ") and "\n" not in err  # before the header
    return err


def test_an_out_under_a_regular_file_is_refused_before_the_header(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "file").write_text("")
    err = _refused(["--algo", "ppo", "--out", str(tmp_path / "file/run"), *FAST], capsys)
    assert f"--out {tmp_path / 'file/run'}: {tmp_path / 'file'} is not a directory" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_a_working_folder_nothing_can_be_written_in_is_refused_before_the_header(
        capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    try:
        with tempfile.NamedTemporaryFile(dir="/sys"):
            pytest.skip("/sys is writable here")
    except OSError:
        pass
    monkeypatch.chdir("/sys")  # sysfs refuses new files, even to root (a chmod would not stop root)
    assert "the default --out runs: cannot write in ." in _refused(["--algo", "ppo", *FAST], capsys)
    assert not Path("/sys/runs").exists()


def test_resume_of_a_run_that_cannot_be_written_is_refused_before_the_header(
        tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "256", "--out", str(out), *FAST]) == 0
    capsys.readouterr()
    real = tempfile.NamedTemporaryFile

    def read_only(*args: object, dir: object = None, **kwargs: object):  # noqa: A002  (tempfile's name)
        if Path(str(dir)).resolve() == out.resolve():  # as a read-only folder does (root ignores chmod)
            raise PermissionError(13, "Permission denied")
        return real(*args, dir=dir, **kwargs)
    monkeypatch.setattr(tempfile, "NamedTemporaryFile", read_only)
    before = sorted(str(p) for p in out.rglob("*"))
    err = _refused(["--resume", str(out), "--timesteps", "512", "--no-progress-bar"], capsys)
    assert f"--resume {out}: cannot write in {out} (Permission denied)" in err
    assert sorted(str(p) for p in out.rglob("*")) == before


def test_resume_falls_back_past_damaged_checkpoints_and_says_so(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "1024", "--out", str(out), *FAST, "--eval-freq", "0"]) == 0
    checkpoints = out / "checkpoints"
    newest = checkpoints / "rl_model_1024_steps.zip"
    with zipfile.ZipFile(newest) as whole:  # a whole zip around a damaged policy
        entries = {name: whole.read(name) for name in whole.namelist()}
    with zipfile.ZipFile(newest, "w") as damaged:
        for name, data in entries.items():
            damaged.writestr(name, b"garbage" if name == "policy.pth" else data)
    stats = checkpoints / "rl_model_vecnormalize_768_steps.pkl"
    stats.write_bytes(stats.read_bytes()[:40])  # statistics cut short
    capsys.readouterr()
    assert train.main(["--resume", str(out), "--timesteps", "1536", "--no-progress-bar"]) == 0
    err = capsys.readouterr().err.strip()
    assert err.startswith("warning: resuming from rl_model_512_steps.zip: the newer checkpoints cannot be loaded")
    assert "\n" not in err and "rl_model_1024_steps.zip" in err and "rl_model_vecnormalize_768_steps.pkl" in err
    # Written at the last step of the rollout 0-512, before its update: the run continues from 0.
    assert train.read_run(out)["sessions"][-1]["start_timesteps"] == 0


def test_help_shows_the_defaults(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit):
        train.main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "task id (default: LightSail-v0)" in text
    assert "(default: the hyperparameter entry's n_timesteps)" in text


def test_a_new_run_never_writes_into_an_old_one(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    argv = ["--algo", "ppo", "--timesteps", "256", *FAST]
    assert train.main(argv) == 0 and train.main(argv) == 0
    first, second = tmp_path / "runs/LightSail-v0-ppo-0", tmp_path / "runs/LightSail-v0-ppo-0_2"
    assert [len(json.loads((d / "run.json").read_text())["sessions"]) for d in (first, second)] == [1, 1]
    assert (tmp_path / "runs/latest").resolve() == second.resolve()
    out = capsys.readouterr().out
    assert out.startswith("training ppo on LightSail-v0, seed 0, 256 steps (whole rollouts: 512)")
    assert train.main([*argv, "--out", str(first)]) == 2
    assert "holds a run already" in capsys.readouterr().err
    # A finished run resumes only to a larger budget.
    assert train.main(["--resume", str(first), "--no-progress-bar"]) == 2
    assert "has trained its 512 steps" in capsys.readouterr().err


def test_resume_skips_a_checkpoint_its_process_did_not_finish_writing(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "1024", "--out", str(out), *FAST]) == 0
    checkpoints = out / "checkpoints"
    assert train.latest_checkpoint(out, normalized=True).name == "rl_model_1024_steps.zip"
    (checkpoints / "rl_model_vecnormalize_1024_steps.pkl").unlink()  # killed between the zip and the statistics
    assert train.latest_checkpoint(out, normalized=True).name == "rl_model_768_steps.zip"
    (checkpoints / "rl_model_768_steps.zip").write_bytes(b"PK\x03\x04 cut short")  # killed inside the zip
    assert train.latest_checkpoint(out, normalized=True).name == "rl_model_512_steps.zip"
    assert train.latest_checkpoint(out, normalized=False).name == "rl_model_1024_steps.zip"
    assert train.main(["--resume", str(out), "--timesteps", "1536", "--no-progress-bar"]) == 0
    assert train.read_run(out)["sessions"][-1]["start_timesteps"] == 0  # 512: before the rollout's update


def test_save_freq_zero_checkpoints_only_at_the_end(tmp_path: Path) -> None:
    out = tmp_path / "run"
    argv = ["--algo", "ppo", "--timesteps", "512", "--out", str(out), *FAST, "--save-freq", "0"]
    assert train.main(argv) == 0
    assert sorted(p.name for p in (out / "checkpoints").glob("*.zip")) == ["rl_model_512_steps.zip"]


@pytest.mark.parametrize("algo", sorted(train.ALGOS))
@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSailDeepDish-v0", "LightSailRealistic-v0"])
def test_shipped_hyperparameters_build_a_model(algo: str, env_id: str) -> None:
    hp = train.load_hyperparams(algo, env_id)
    assert {"n_envs", "n_timesteps", "policy", "normalize"} <= set(hp)
    env = train.make_env(env_id, 1, 0, "dummy", train.normalize_kwargs(hp.pop("normalize")), 0.99, training=True)
    hp.pop("n_envs"), hp.pop("n_timesteps")
    model = train.ALGOS[algo](hp.pop("policy"), env, **train.algo_kwargs(hp, 2))
    assert model.policy is not None


def test_every_task_has_shipped_hyperparameters_for_every_algorithm() -> None:
    """train.py and the tuner read their defaults from agents/hyperparams; a task without an entry
    cannot be trained at all (LightSailUncertain-v0 once shipped without one)."""
    for algo in train.ALGOS:
        for env_id in TASKS:
            assert train.load_hyperparams(algo, env_id)["n_timesteps"] > 0, (algo, env_id)


def test_resume_without_a_checkpoint_is_a_one_line_error(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "run.json").write_text(json.dumps({"config": {"hyperparams": {}}}))
    assert train.main(["--resume", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "not a run configuration (lacks algo" in err and "\n" not in err
    config = {"algo": "ppo", "env": "LightSail-v0", "seed": 0, "vec_env": "batched", "eval_freq": 0,
              "eval_episodes": 1, "save_freq": 0, "hyperparams_file": "x.yml", "hyperparams": {"n_timesteps": 10}}
    (tmp_path / "run.json").write_text(json.dumps({"config": config}))
    assert train.main(["--resume", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "no complete checkpoint to resume from" in err and "\n" not in err


def test_a_signal_stops_the_run_at_the_next_step_and_never_inside_a_write(tmp_path: Path,
                                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """Raised inside torch's zip writer, a Ctrl-C broke the checkpoint and ended the run with an
    error; raised inside loss.backward, it failed a tuning trial. The handler only records it."""
    from stable_baselines3.common.callbacks import CheckpointCallback
    from stable_baselines3.common.env_util import make_vec_env

    from agents import training

    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    monkeypatch.setitem(training._stop, "requested", None)
    training.stop_on_signals()
    try:
        model = PPO("MlpPolicy", make_vec_env("Pendulum-v1", n_envs=1), n_steps=64, batch_size=64)
        saved = []
        real_save = model.save

        def save_with_a_signal(path, *args, **kwargs):
            os.kill(os.getpid(), signal.SIGTERM)  # arrives mid-write
            real_save(path, *args, **kwargs)
            saved.append(Path(path))

        model.save = save_with_a_signal
        model.learn(1000, callback=[training.StopOnSignal(), CheckpointCallback(10, str(tmp_path))])
        assert training.stop_requested() == "SIGTERM"
        assert model.num_timesteps == 11  # the write was at step 10; the run stopped at the next
        assert len(saved) == 1 and zipfile.is_zipfile(saved[0])
        PPO.load(saved[0])
        with pytest.raises(KeyboardInterrupt, match="SIGINT"):  # a second signal aborts
            os.kill(os.getpid(), signal.SIGINT)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def test_the_selection_episodes_run_as_one_batch_each_from_its_own_seed(tmp_path: Path) -> None:
    """One environment per selection episode, batched whatever the training envs are, so a step of
    the evaluation is one call; each episode is the one a single env seeded eval seed + i plays."""
    import gymnasium as gym
    import numpy as np
    from stable_baselines3.common.evaluation import evaluate_policy

    config, _ = train.run_config(train.parse_args(["--algo", "ppo", "--timesteps", "256", "--vec-env", "dummy", *FAST,
                                                "--eval-episodes", "3", "--out", str(tmp_path / "run")]))
    setup = train.prepare(config)
    try:
        assert isinstance(setup.eval_env.unwrapped, train.BatchedVecEnv) and setup.eval_env.num_envs == 3
        setup.eval_env.seed(config["seed"] + train.EVAL_SEED_OFFSET)
        setup.eval_env.obs_rms = setup.train_env.obs_rms
        returns, _ = evaluate_policy(setup.model, setup.eval_env, n_eval_episodes=3, deterministic=True,
                                     return_episode_rewards=True)
        for i, batched in enumerate(returns):
            env = gym.make("LightSail-v0")
            obs, _ = env.reset(seed=config["seed"] + train.EVAL_SEED_OFFSET + i)
            total, done = 0.0, False
            while not done:
                action, _ = setup.model.predict(setup.eval_env.normalize_obs(obs[None]), deterministic=True)
                obs, reward, terminated, truncated, _ = env.step(action[0])
                total, done = total + reward, terminated or truncated
            assert np.isclose(total, batched, rtol=1e-5), i
    finally:
        setup.close()


def test_a_signal_during_the_last_step_leaves_the_run_finished(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Nothing is left to resume when the signal lands in the budget's last step: the run is finished,
    with its final model, not 'interrupted' with a resume hint that could only fail."""
    def signal_at_the_end(self) -> bool:
        if self.num_timesteps >= 256:
            train._stop["requested"] = "SIGTERM"
        return True

    monkeypatch.setitem(train._stop, "requested", None)
    monkeypatch.setattr(train.StopOnSignal, "_on_step", signal_at_the_end)
    out = tmp_path / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "256", "--out", str(out), *FAST]) == 0
    assert json.loads((out / "run.json").read_text())["sessions"][0]["status"] == "finished"
    assert (out / "final_model.zip").is_file()


def interrupt_at(steps: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """The next run stops as on Ctrl-C at its first step at or past ``steps``."""
    def signal_at(self) -> bool:
        if self.num_timesteps >= steps:
            train._stop["requested"] = "SIGINT"
        return train._stop["requested"] is None

    monkeypatch.setitem(train._stop, "requested", None)
    monkeypatch.setattr(train.StopOnSignal, "_on_step", signal_at)


def test_a_resumed_run_evaluates_where_an_uninterrupted_one_does_and_trains_its_budget(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture) -> None:
    """Counted from the resume, the schedule missed the uninterrupted run's points (a run resumed at
    1,000 of 2,048 steps with --eval-freq 2048 never evaluated), and PPO's rollouts from the resume
    point overshot the budget announced (1,324 of 1,024 here)."""
    argv = ["--algo", "ppo", "--timesteps", "1024", *FAST, "--save-freq", "0"]
    assert train.main([*argv, "--out", str(tmp_path / "straight")]) == 0
    out = tmp_path / "resumed"
    interrupt_at(300, monkeypatch)
    assert train.main([*argv, "--out", str(out)]) == 130
    assert train.read_run(out)["sessions"][0]["timesteps"] == 300
    monkeypatch.undo()
    monkeypatch.setitem(train._stop, "requested", None)
    capsys.readouterr()
    assert train.main(["--resume", str(out), "--no-progress-bar"]) == 0
    output = capsys.readouterr().out
    # The rollout 0-512 was cut at 300, before PPO's update: the run continues from 0.
    assert output.startswith("resuming rl_model_300_steps.zip at 0 steps, the end of the last rollout it learnt from")
    assert "resuming ppo on LightSail-v0, seed 0, 1,024 steps" in output and "finished: 1,024 steps" in output
    assert PPO.load(out / "final_model.zip").num_timesteps == 1024
    for run in (tmp_path / "straight", out):
        with np.load(run / "evaluations.npz") as log:
            assert log["timesteps"].tolist() == [256, 512, 768, 1024], run


@pytest.mark.parametrize("eval_freq", ["10000", "384"])
def test_a_run_always_ends_with_a_best_model_when_it_evaluates(eval_freq: str, tmp_path: Path) -> None:
    """A budget below --eval-freq (or not a multiple of it) ended without a final evaluation: no
    best_model.zip, and the README's next command (evaluate.py --agent runs/latest/best_model.zip) failed."""
    out = tmp_path / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "512", "--out", str(out), *FAST, "--eval-freq", eval_freq]) == 0
    assert (out / "best_model.zip").is_file() and train.read_best(out)["timesteps"] == 512
    with np.load(out / "evaluations.npz") as log:
        assert log["timesteps"].tolist() == ([384, 512] if eval_freq == "384" else [512])


def test_an_off_policy_run_resumed_inside_a_chunk_trains_its_budget(tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """SAC collects train_freq steps between updates and stopped only at a chunk's end: resumed at
    101 with train_freq 8, a 256-step budget trained 261."""
    (tmp_path / "sac.yml").write_text("LightSail-v0:\n  n_timesteps: 256\n  policy: MlpPolicy\n  normalize: false\n"
                                      "  learning_starts: 50\n  train_freq: 8\n  gradient_steps: 1\n"
                                      "  policy_kwargs: {net_arch: [8, 8]}\n")
    out = tmp_path / "run"
    interrupt_at(101, monkeypatch)
    assert train.main(["--algo", "sac", "--config", str(tmp_path / "sac.yml"), "--out", str(out), *FAST,
                       "--n-envs", "1", "--eval-freq", "0"]) == 130
    monkeypatch.undo()
    monkeypatch.setitem(train._stop, "requested", None)
    assert train.main(["--resume", str(out), "--no-progress-bar"]) == 0
    assert [s["timesteps"] for s in train.read_run(out)["sessions"]] == [101, 256]
    assert train.ALGOS["sac"].load(out / "final_model.zip").num_timesteps == 256


def test_resume_refuses_a_flag_that_contradicts_the_run_and_applies_the_others(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """--resume read only --timesteps: --algo sac resumed a PPO run as PPO, --eval-freq 0 still evaluated."""
    out = tmp_path / "run"
    assert train.main(["--algo", "ppo", "--timesteps", "256", "--out", str(out), *FAST]) == 0
    before = sorted(str(p) for p in out.rglob("*"))
    capsys.readouterr()
    for flags, message in ((["--algo", "sac"], "--algo sac contradicts the run in"),
                           (["--env", "LightSail3D-v0"], "--env LightSail3D-v0 contradicts"),
                           (["--seed", "3"], "--seed 3 contradicts"), (["--n-envs", "4"], "--n-envs 4 contradicts"),
                           (["--eval-episodes", "5"], "--eval-episodes 5 contradicts"),
                           (["--config", "other.yml"], "--config other.yml contradicts"),
                           (["--out", str(tmp_path / "elsewhere")], "--out")):
        assert message in _refused(["--resume", str(out), "--timesteps", "1024", *flags], capsys)
    assert sorted(str(p) for p in out.rglob("*")) == before
    capsys.readouterr()
    # The run's own values are no contradiction; --eval-freq and --save-freq apply, and it says so.
    assert train.main(["--resume", str(out), "--timesteps", "1024", "--algo", "ppo", "--seed", "0", "--n-envs", "2",
                       "--eval-freq", "0", "--save-freq", "0", "--no-progress-bar"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[:2] == ["resuming with --eval-freq 0 (the run had 256)",
                         "resuming with --save-freq 0 (the run had 256)"]
    with np.load(out / "evaluations.npz") as log:
        assert log["timesteps"].tolist() == [256, 512]  # none since the resume
    assert train.read_run(out)["config"]["eval_freq"] == 0
    assert sorted(p.name for p in (out / "checkpoints").glob("*.zip")) == ["rl_model_1024_steps.zip",
                                                                          "rl_model_256_steps.zip",
                                                                          "rl_model_512_steps.zip"]


def test_a_yaml_that_cannot_be_parsed_names_the_line(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.yml").write_text("LightSail-v0:\n  n_timesteps: 100\n gamma: 0.9\n")
    err = _refused(["--algo", "ppo", "--config", "bad.yml", "--no-progress-bar"], capsys)
    assert "bad.yml: cannot read hyperparameters (ParserError: " in err and "at line 3, column 2)" in err
    assert not (tmp_path / "runs").exists()
