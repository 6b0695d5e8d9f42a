"""Hyperparameter search at a tiny budget: trials run, are pruned on the success rate, and the
best trial is a YAML entry that train.py trains from."""

from __future__ import annotations

from pathlib import Path

import optuna
import pytest
import yaml
from optuna.trial import TrialState

from agents import training, tuning

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
