"""Hyperparameter search at a tiny budget: trials run, are pruned on the success rate, and the
best trial is a YAML entry that train.py trains from."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import optuna
import pytest
import yaml
from optuna.trial import TrialState

from agents import kept, training, tuning

SETTINGS = {"timesteps": 256, "eval_freq": 128, "eval_episodes": 2, "seed": 0}


@pytest.mark.parametrize("algo", ["ppo", "td3"])
def test_the_best_trial_is_a_config_train_py_reads(algo: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    study = tuning.tune(algo, "LightSail-v0", "sqlite:///runs/grid.db", "t", 2, SETTINGS, tmp_path / "runs/t")
    complete = study.get_trials(states=(TrialState.COMPLETE,))
    assert len(complete) == 2
    for trial in complete:  # the value is the best evaluation's success rate, as reported
        assert trial.value == max(trial.intermediate_values.values())
    (tmp_path / "best.yml").write_text(tuning.best_yaml(study, "LightSail-v0"))
    entry = yaml.safe_load((tmp_path / "best.yml").read_text())["LightSail-v0"]
    assert entry == study.best_trial.user_attrs["hyperparams"]
    assert training.main(["--algo", algo, "--config", "best.yml", "--timesteps", "64", "--eval-freq", "0",
                          "--no-progress-bar"]) == 0


def test_the_recurrent_search_space_trains(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A draw of RecurrentPPO's space (its smallest rollout: a whole study would train 8k-step rollouts
    here) is a YAML entry train.py trains, with the LSTM it names and no stacked history."""
    monkeypatch.chdir(tmp_path)
    params = {"n_steps": 64, "log_std_init": -1.0, "batch_size": 64, "n_epochs": 5, "learning_rate": 3e-4,
              "gamma": 0.99, "gae_lambda": 0.95, "clip_range": 0.2, "ent_coef": 1e-6, "net_arch": "small",
              "activation_fn": "tanh", "lstm_hidden_size": 32, "enable_critic_lstm": False}
    hp = {"policy": "MlpLstmPolicy", "n_timesteps": 128, **tuning.SAMPLERS["recurrent_ppo"](optuna.trial.FixedTrial(params))}
    assert hp["frame_stack"] == 1
    off_policy = tuning.SAMPLERS["sac"](optuna.trial.FixedTrial({
        "train_freq": 4, "learning_rate": 1e-4, "batch_size": 64, "buffer_size": 10_000, "learning_starts": 100,
        "gamma": 0.99, "tau": 0.01, "net_arch": "small", "activation_fn": "tanh"}))
    assert off_policy.get("frame_stack", 1) == 1  # normalised, SAC's and TD3's replay buffer cannot hold a stack
    (tmp_path / "rp.yml").write_text(yaml.safe_dump({"LightSail-v0": hp}))
    assert training.main(["--algo", "recurrent_ppo", "--config", "rp.yml", "--n-envs", "1", "--eval-freq", "0",
                          "--out", "run", "--no-progress-bar"]) == 0
    policy = training.ALGOS["recurrent_ppo"].load(tmp_path / "run" / "final_model.zip").policy
    assert policy.lstm_actor.hidden_size == 32 and policy.lstm_critic is None


SAC_CONFIG = ["train_freq=4", "learning_rate=3.77e-5", "batch_size=512", "buffer_size=100000",
              "learning_starts=100", "gamma=0.995", "tau=0.02", "net_arch=medium", "activation_fn=tanh"]


def test_an_enqueued_configuration_is_the_next_trial(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    storage = f"sqlite:///{tmp_path}/grid.db"
    assert tuning.main(["--algo", "sac", "--storage", storage, "--study", "q", "--enqueue", *SAC_CONFIG]) == 0
    assert "queued in q" in capsys.readouterr().out
    study = tuning.tune("sac", "LightSail-v0", storage, "q", 1, SETTINGS, tmp_path / "runs")
    (trial,) = study.get_trials(states=(TrialState.COMPLETE,))
    assert trial.params == {"train_freq": 4, "learning_rate": 3.77e-5, "batch_size": 512, "buffer_size": 100_000,
                            "learning_starts": 100, "gamma": 0.995, "tau": 0.02, "net_arch": "medium",
                            "activation_fn": "tanh"}
    trained = training.read_run(Path(trial.user_attrs["run_dir"]))["config"]["hyperparams"]
    assert trained["learning_rate"] == 3.77e-5 and trained["policy_kwargs"] == "dict(net_arch=[256, 256], activation_fn=nn.Tanh)"


def test_an_enqueued_number_without_a_dot_is_a_number(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """YAML reads 3e-4 as text: the string '3e-4' was queued, and the trial failed when it trained."""
    storage = f"sqlite:///{tmp_path}/grid.db"
    items = [item for item in SAC_CONFIG if not item.startswith("learning_rate=")]
    assert tuning.main(["--algo", "sac", "--storage", storage, "--study", "q", "--enqueue", *items,
                        "learning_rate=3e-4"]) == 0
    (waiting,) = optuna.load_study(study_name="q", storage=storage).get_trials()
    queued = waiting.system_attrs["fixed_params"]["learning_rate"]
    assert queued == 3e-4 and isinstance(queued, float)
    capsys.readouterr()
    assert tuning.main(["--algo", "sac", "--storage", f"sqlite:///{tmp_path}/other.db", "--enqueue", *items,
                        "learning_rate=fast"]) == 2
    errors = capsys.readouterr().err.splitlines()
    assert errors == ["error: --enqueue learning_rate=fast: learning_rate must be a number"]
    assert not (tmp_path / "other.db").exists()


@pytest.mark.parametrize("change, message", [
    (["tau=0.02"], "; missing: tau"),  # left out
    (["batch_size=500"], "'500' not in (64, 128, 256, 512)"),
    (["learning_rate=1.0"], "out of the range"),
    (["tau=0.02", "momentum=0.9"], "; not in it: momentum"),
    (["tau"], "'tau': expected KEY=VALUE"),
])
def test_a_configuration_outside_the_search_space_is_refused_before_the_storage_opens(
        change: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    items = [item for item in SAC_CONFIG if item.split("=")[0] not in {c.split("=")[0] for c in change}]
    items += [] if change == ["tau=0.02"] else change
    assert tuning.main(["--algo", "sac", "--storage", f"sqlite:///{tmp_path}/grid.db", "--enqueue", *items]) == 2
    errors = capsys.readouterr().err.splitlines()
    assert len(errors) == 1 and message in errors[0]
    assert not (tmp_path / "grid.db").exists()


def test_a_residual_study_searches_the_correction_size_and_trains_residual_policies(tmp_path: Path) -> None:
    study = tuning.tune("ppo", "LightSail-v0", f"sqlite:///{tmp_path}/grid.db", "r", 1,
                        {**SETTINGS, "residual": "lqg"}, tmp_path / "runs")
    (trial,) = study.get_trials(states=(TrialState.COMPLETE,))
    assert 0.05 <= trial.params["residual_scale"] <= 1.0
    recorded = training.read_run(Path(trial.user_attrs["run_dir"]))["config"]["hyperparams"]
    assert recorded["residual"] == "lqg" and recorded["residual_scale"] == trial.params["residual_scale"]


def test_a_trial_below_the_pruner_stops_at_its_first_evaluation(tmp_path: Path) -> None:
    everything = optuna.pruners.ThresholdPruner(lower=1.5)  # no success rate reaches it
    study = tuning.tune("ppo", "LightSail-v0", f"sqlite:///{tmp_path}/grid.db", "p", 1, SETTINGS, tmp_path / "runs",
                        pruner=everything)
    (trial,) = study.get_trials()
    assert trial.state == TrialState.PRUNED and len(trial.intermediate_values) == 1
    assert training.read_run(Path(trial.user_attrs["run_dir"]))["sessions"][0]["status"] == "stopped"


def test_a_study_never_reuses_another_studys_trial_folder(tmp_path: Path) -> None:
    """A second study of the same name in another storage trained its trial 0 into the first's
    trial-0, read that one's best_model.json and reported its score as its own."""
    old = tmp_path / "runs/trial-0"
    old.mkdir(parents=True)
    record = '{"timesteps": 1, "success_rate": 0.99, "mean_return": 1e9, "episodes": 2}'
    (old / "best_model.json").write_text(record)
    study = tuning.tune("ppo", "LightSail-v0", f"sqlite:///{tmp_path}/other.db", "t", 1, SETTINGS, tmp_path / "runs")
    (trial,) = study.get_trials()
    assert trial.value != 0.99
    assert (old / "best_model.json").read_text() == record and sorted(p.name for p in old.iterdir()) == ["best_model.json"]
    assert trial.user_attrs["run_dir"] == str(tmp_path / "runs/trial-0_2")
    assert trial.value == training.read_best(tmp_path / "runs/trial-0_2")["success_rate"]


def test_a_resumed_study_samples_new_configurations(tmp_path: Path) -> None:
    """Seeded alike in every session, the sampler drew the same first configurations again."""
    storage = f"sqlite:///{tmp_path}/grid.db"
    tuning.tune("ppo", "LightSail-v0", storage, "s", 1, SETTINGS, tmp_path / "runs")
    study = tuning.tune("ppo", "LightSail-v0", storage, "s", 2, SETTINGS, tmp_path / "runs")
    first, second = study.get_trials()
    assert first.params != second.params


class SignalAtFirstReport(optuna.pruners.BasePruner):
    """Never prunes; sends SIGTERM to this process the first time it is asked."""

    def __init__(self) -> None:
        self.sent = False

    def prune(self, study: optuna.Study, trial: optuna.trial.FrozenTrial) -> bool:
        if not self.sent:
            self.sent = True
            os.kill(os.getpid(), signal.SIGTERM)
        return False


def test_a_stopped_trial_is_queued_again_and_resumes_its_checkpoint(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    storage = f"sqlite:///{tmp_path}/grid.db"
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    monkeypatch.setitem(training._stop, "requested", None)
    training.stop_on_signals()
    try:
        with pytest.raises(KeyboardInterrupt):
            tuning.tune("ppo", "LightSail-v0", storage, "r", 1, SETTINGS, tmp_path / "runs", pruner=SignalAtFirstReport())
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    stopped, queued = optuna.load_study(study_name="r", storage=storage).get_trials()
    assert stopped.state == TrialState.FAIL and queued.state == TrialState.WAITING
    assert queued.params == stopped.params and queued.user_attrs["run_dir"] == stopped.user_attrs["run_dir"]
    run_dir = Path(stopped.user_attrs["run_dir"])
    assert training.read_run(run_dir)["sessions"][0]["status"] == "interrupted"

    monkeypatch.setitem(training._stop, "requested", None)  # the next session, with a wider search space
    sample = tuning.SAMPLERS["ppo"]
    monkeypatch.setitem(tuning.SAMPLERS, "ppo", lambda trial: {**sample(trial),
                                                               "n_epochs": trial.suggest_int("new_knob", 1, 2)})
    study = tuning.tune("ppo", "LightSail-v0", storage, "r", 1, SETTINGS, tmp_path / "runs")
    (done,) = study.get_trials(states=(TrialState.COMPLETE,))
    assert done.number == queued.number and done.user_attrs["run_dir"] == str(run_dir)
    # The retry trained its original's configuration, not a new draw of the wider space.
    assert done.user_attrs["hyperparams"] == stopped.user_attrs["hyperparams"] and "new_knob" not in done.params
    sessions = training.read_run(run_dir)["sessions"]
    assert [s["status"] for s in sessions] == ["interrupted", "finished"]
    # Stopped inside PPO's first rollout, before its update: the retry continues from its start.
    assert sessions[0]["timesteps"] > 0 and sessions[1]["start_timesteps"] == 0
    assert done.value == training.read_best(run_dir)["success_rate"]


def test_a_trial_resumed_before_its_first_evaluation_is_scored(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """Stopped at 100 of 256 steps with one evaluation at 256: the resumed session counted its schedule
    from the resume, never evaluated, and the tuner failed on the missing best_model.json."""
    storage = f"sqlite:///{tmp_path}/grid.db"
    settings = {**SETTINGS, "eval_freq": 256}

    def signal_at_100(self) -> bool:
        if self.num_timesteps >= 100:
            training._stop["requested"] = "SIGTERM"
        return training._stop["requested"] is None

    monkeypatch.setitem(training._stop, "requested", None)
    with monkeypatch.context() as patch:
        patch.setattr(training.StopOnSignal, "_on_step", signal_at_100)
        with pytest.raises(KeyboardInterrupt):
            tuning.tune("td3", "LightSail-v0", storage, "r", 1, settings, tmp_path / "runs")
    monkeypatch.setitem(training._stop, "requested", None)
    study = tuning.tune("td3", "LightSail-v0", storage, "r", 1, settings, tmp_path / "runs")
    (done,) = study.get_trials(states=(TrialState.COMPLETE,))
    run_dir = Path(done.user_attrs["run_dir"])
    assert [(s["start_timesteps"], s["timesteps"]) for s in training.read_run(run_dir)["sessions"]] == [(0, 100),
                                                                                                      (100, 256)]
    assert done.intermediate_values.keys() == {256} and done.value == training.read_best(run_dir)["success_rate"]


def finished_study(storage: str, name: str) -> optuna.Study:
    """A study with a complete and a pruned trial, as the tuner leaves them."""
    study = optuna.create_study(storage=storage, study_name=name, direction="maximize")
    space = {"learning_rate": optuna.distributions.FloatDistribution(1e-5, 3e-3, log=True),
             "n_steps": optuna.distributions.CategoricalDistribution([64, 128])}
    for value, state, steps in ((0.8, TrialState.COMPLETE, {100: 0.5, 200: 0.8}), (None, TrialState.PRUNED, {100: 0.1})):
        study.add_trial(optuna.trial.create_trial(
            state=state, value=value, params={"learning_rate": 1e-4, "n_steps": 128 if value else 64},
            distributions=space, intermediate_values=steps,
            user_attrs={"hyperparams": {"policy": "MlpPolicy", "n_steps": 128, "n_timesteps": 200}}))
    return study


def test_exported_trials_come_back_in_a_fresh_storage(tmp_path: Path) -> None:
    """A fresh checkout has no runs/: the trials kept with the code (--export) are the study's
    again (--import), once, for the sampler, the pruner and best.yml."""
    finished_study(f"sqlite:///{tmp_path}/a.db", "s")
    out = tmp_path / "kept/s.json"
    assert tuning.main(["--algo", "ppo", "--storage", f"sqlite:///{tmp_path}/a.db", "--study", "s",
                        "--export", str(out)]) == 0
    exported = kept.read(out, "s", "--import")
    fresh = optuna.create_study(storage=f"sqlite:///{tmp_path}/b.db", study_name="s", direction="maximize")
    assert kept.add_trials(fresh, exported) == 2 and kept.add_trials(fresh, exported) == 0
    old = optuna.load_study(study_name="s", storage=f"sqlite:///{tmp_path}/a.db").get_trials()
    new = fresh.get_trials()
    for before, after in zip(old, new):
        assert (after.state, after.value, after.params, after.intermediate_values, after.distributions) == \
            (before.state, before.value, before.params, before.intermediate_values, before.distributions)
        assert after.user_attrs["hyperparams"] == before.user_attrs["hyperparams"]
    assert "success rate 80.0%" in tuning.best_yaml(fresh, "LightSail-v0")
    # Exported again from the fresh storage, each trial still comes once; a study's own trials
    # (numbered from 0 in every storage) are not mistaken for the kept ones.
    kept.write(tmp_path / "again.json", kept.kept_trials(fresh))
    assert kept.add_trials(fresh, kept.read(tmp_path / "again.json", "s", "--import")) == 0
    own = finished_study(f"sqlite:///{tmp_path}/c.db", "s")
    assert kept.add_trials(own, exported) == 2 and len(own.get_trials()) == 4


def test_kept_trials_of_another_study_or_a_missing_one_are_refused(tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    finished_study(f"sqlite:///{tmp_path}/a.db", "s")
    out = tmp_path / "s.json"
    assert tuning.main(["--algo", "ppo", "--storage", f"sqlite:///{tmp_path}/a.db", "--study", "s",
                        "--export", str(out)]) == 0
    capsys.readouterr()
    fresh = f"sqlite:///{tmp_path}/b.db"
    assert tuning.main(["--algo", "ppo", "--storage", fresh, "--study", "other", "--import", str(out),
                        "--runs-dir", str(tmp_path / "runs")]) == 2
    assert tuning.main(["--algo", "ppo", "--storage", fresh, "--study", "other", "--export", str(out)]) == 2
    (tmp_path / "empty.db").touch()
    assert tuning.main(["--algo", "ppo", "--storage", f"sqlite:///{tmp_path}/empty.db", "--study", "s",
                        "--export", str(tmp_path / "e.json")]) == 2
    errors = capsys.readouterr().err.splitlines()
    assert len(errors) == 3 and "holds study 's', not 'other'" in errors[0] and "no study 'other'" in errors[1]
    assert "does not exist or is empty" in errors[2] and (tmp_path / "empty.db").stat().st_size == 0
    assert not (tmp_path / "b.db").exists() and not (tmp_path / "runs").exists()


def test_a_kept_file_is_checked_whole_before_the_storage_is_touched(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A damaged record is refused (one line, exit 2) before a study is made; a record listed
    twice is added once."""
    finished_study(f"sqlite:///{tmp_path}/a.db", "s")
    good = kept.kept_trials(optuna.load_study(study_name="s", storage=f"sqlite:///{tmp_path}/a.db"))
    damaged = tmp_path / "damaged.json"
    damaged.write_text(json.dumps({**good, "trials": [good["trials"][0], {"origin": "s#9@?"}]}))
    assert tuning.main(["--algo", "ppo", "--storage", f"sqlite:///{tmp_path}/b.db", "--study", "s",
                        "--import", str(damaged)]) == 2
    assert "trial 1 is not a kept trial (KeyError: 'state')" in capsys.readouterr().err
    assert not (tmp_path / "b.db").exists()
    twice = tmp_path / "twice.json"
    twice.write_text(json.dumps({**good, "trials": good["trials"] + good["trials"]}))
    assert tuning.main(["--algo", "ppo", "--storage", f"sqlite:///{tmp_path}/b.db", "--study", "s",
                        "--import", str(twice)]) == 0
    assert len(optuna.load_study(study_name="s", storage=f"sqlite:///{tmp_path}/b.db").get_trials()) == 2
