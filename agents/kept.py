"""A study's finished Optuna trials kept as JSON with the code, read back into any storage.

``runs/`` (the grid's and the tuner's SQLite files) is not versioned, and a fresh checkout starts
without it: the grid's ``export`` and the tuner's ``--export`` write a study's finished trials
(parameters, scores, the intermediate values the pruner compares, the user attributes: a tuning
trial's hyperparameters, a grid cell's results) to a file that can be committed; ``import`` and
``--import`` make them the study's again. A trial is known by its origin (the study, its number
and its start there), so an import adds each trial once, however often it is repeated.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import optuna
from optuna.distributions import distribution_to_json, json_to_distribution
from optuna.trial import FrozenTrial, TrialState, create_trial

from agents import cli

FINISHED = (TrialState.COMPLETE, TrialState.PRUNED)


def origin(study_name: str, trial: FrozenTrial) -> str:
    """Where a finished trial first ran (an imported trial keeps its own; numbers alone repeat in
    every storage)."""
    started = trial.datetime_start.isoformat() if trial.datetime_start else "?"
    return trial.user_attrs.get("imported") or f"{study_name}#{trial.number}@{started}"


def kept_trials(study: optuna.Study) -> dict[str, Any]:
    """The study's attributes and its finished trials, as JSON."""
    return {"study": study.study_name, "user_attrs": study.user_attrs, "trials": [
        {"origin": origin(study.study_name, t), "state": t.state.name, "value": t.value, "params": t.params,
         "distributions": {name: json.loads(distribution_to_json(d)) for name, d in t.distributions.items()},
         "intermediate_values": {str(step): v for step, v in t.intermediate_values.items()},
         "user_attrs": {key: v for key, v in t.user_attrs.items() if key != "imported"}}
        for t in study.get_trials(deepcopy=False, states=FINISHED)]}


def add_trials(study: optuna.Study, kept: dict[str, Any]) -> int:
    """Add the ``kept`` trials (as :func:`read` gives them) the study lacks; returns how many. One
    process at a time: two importing into one study at once would each add every trial."""
    if kept["study"] != study.study_name:
        raise ValueError(f"the trials are study {kept['study']!r}'s, not {study.study_name!r}'s")
    present = {origin(study.study_name, t) for t in study.get_trials(deepcopy=False)}
    added = 0
    for trial in kept["trials"]:
        if trial.user_attrs["imported"] not in present:
            study.add_trial(trial)
            present.add(trial.user_attrs["imported"])
            added += 1
    return added


def read(path: Path, study_name: str, flag: str) -> dict[str, Any]:
    """The kept trials of ``study_name`` in ``path``, every one checked and made a trial (each
    remembering its origin) before any storage is touched, or a one-line :class:`cli.UsageError`
    naming ``flag`` and what is wrong with the file."""
    try:
        kept = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise cli.UsageError(f"{flag} {path}: {getattr(err, 'strerror', None) or err}") from err
    if not isinstance(kept, dict) or not isinstance(kept.get("trials"), list):
        raise cli.UsageError(f"{flag} {path}: not a file of kept trials (written by an export)")
    if kept.get("study") != study_name:
        raise cli.UsageError(f"{flag} {path} holds study {kept.get('study')!r}, not {study_name!r}")
    trials = []
    for number, record in enumerate(kept["trials"]):
        try:
            trials.append(create_trial(
                state=TrialState[record["state"]], value=record["value"], params=record["params"],
                distributions={name: json_to_distribution(json.dumps(d))
                               for name, d in record["distributions"].items()},
                intermediate_values={int(step): v for step, v in record["intermediate_values"].items()},
                user_attrs={**record["user_attrs"], "imported": str(record["origin"])}))
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise cli.UsageError(f"{flag} {path}: trial {number} is not a kept trial "
                                 f"({type(err).__name__}: {err})") from err
    return {**kept, "trials": trials}


def write(path: Path, kept: dict[str, Any]) -> None:
    """Write :func:`kept_trials` to ``path`` (its folder made if need be), whole or not at all."""
    path.parent.mkdir(parents=True, exist_ok=True)
    cli.write_whole(path, json.dumps(kept, indent=1) + "\n")
