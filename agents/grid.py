"""The benchmark grid as shared work: every (agent, task, hyperparameters, seed) cell is one
Optuna trial in a relational database, taken by whichever worker asks next.

    python -m agents.grid run                 # a worker: takes cells until none is left
    python -m agents.grid status              # done, running (where), failed, what remains
    python -m agents.grid render --readme docs/learners.md   # the table in docs/learners.md from the database
    python -m agents.grid redo --agents lqg   # queue cells again after their code changed
    python -m agents.grid export --study realistic --file benchmarks/results/grid/realistic.json
    python -m agents.grid import --study realistic --file benchmarks/results/grid/realistic.json

The default storage is a SQLite file, ``runs/grid.db``: nothing to set up. With
``--storage postgresql://user:password@host/db`` the same commands run one grid from any
number of machines (start ``run`` on each). Why Optuna's storage rather than SQLAlchemy
directly: its trial queue (``enqueue_trial`` / ``ask``) hands each waiting trial to exactly
one worker, its heartbeats find the cells of workers that died, and its tools (the
dashboard, ``optuna.load_study``) read the results with no code of ours.

``runs/`` is not versioned: ``export`` writes the grid's settings and finished cells to a file that
can be committed, and ``import`` makes them a new grid in any storage (a fresh checkout's), with
the cells they lack queued; ``run`` with the grid's arguments then goes on (:mod:`agents.kept`).

A cell's files live in ``--runs-dir`` (``runs/grid/<study>/<cell>``). A cell whose worker
stops (Ctrl-C, SIGTERM) is put back at once; one whose worker dies stops beating and is put
back after ``--grace`` seconds. Either way the next worker resumes it from its newest
checkpoint if it sees the same ``--runs-dir`` (a shared file system across machines), and
starts it again otherwise.
"""

from __future__ import annotations

import argparse
import fcntl
import math
import os
import socket
import sys
import threading
import time
import warnings
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import optuna
from optuna.storages import RDBStorage, RetryHeartbeatStaleTrialCallback, fail_stale_trials
from optuna.trial import FrozenTrial, TrialState
from optuna.exceptions import UpdateFinishedTrialError
from sqlalchemy.exc import IntegrityError, OperationalError, ProgrammingError, SQLAlchemyError

from agents import cli, evaluation, kept, training
from agents.sb3 import ALGOS, ModelLoadError, load_hyperparams, policy_of, versions
from sail_env.tasks import PLANAR_TASKS, RIGID3D_TASKS, TASKS

DEFAULT_STORAGE = "sqlite:///runs/grid.db"
DEFAULT_STUDY = "planar"
#: The classical rows of a grid unless ``--classical`` names others.
CLASSICAL = ("passive", "lqr", "lqg")
#: Every agent a grid can hold: evaluate.py's baselines (the bounds ``lqr-oracle`` and ``lqg-oracle``
#: and the adaptive ``lqg-mm`` among them), then the learners.
AGENTS = (*evaluation.BASELINES, *sorted(ALGOS))
#: The bounds that read the simulator's truth: the table's ceiling is the best of them on a task.
CEILING = ("lqr-oracle", "lqg-oracle")
#: Agents for the 3D tasks only (the adaptive LQG's bank varies the 3D sail's beam power).
THREE_D_ONLY = frozenset({"lqg-mm", "lqg-mm-offset"})
#: What the table compares every row with, episode by episode.
REFERENCE = "lqg"
#: The table's rows on each task: the classical designs, the learners, the bounds last.
ROW_ORDER = (*CLASSICAL, "lqg-mm", "lqg-mm-offset", *sorted(ALGOS), *CEILING)
#: The learners a grid runs unless ``--algos`` names others (``recurrent_ppo`` only when asked).
LEARNERS = ("ppo", "sac", "td3")
#: ``tuned``: the shipped YAML; ``default``: what a user tries first, the library's own
#: defaults (no normalisation, one env, ``log_std_init = 0``) on the same budget.
HYPERPARAMETERS = ("tuned", "default")
EPISODES = 200
SEEDS = (0, 1, 2)
#: Tries to open (and on first use, create) the storage.
SCHEMA_ATTEMPTS = 4
#: A cell that fails this many times is left failed.
MAX_RETRY = 3
CELL_PARAMS = ("env", "agent", "hyperparameters", "seed")
#: Where a cell runs, for ``status``.
WORKER = f"{socket.gethostname()}:{os.getpid()}"
#: ``--grace`` must be at least this many heartbeats: a live worker whose beat is a little late
#: (a busy database, a slow disk) must not have its cell handed to a second worker.
GRACE_HEARTBEATS = 2
COMMANDS = {"run": "a worker: takes cells until none is left (creates the grid on first use)",
            "status": "done, running (where), failed, what remains",
            "render": "the results table (--readme: also into that file's --section markers)",
            "redo": "queue the cells of --agents on --envs again (after their code changed)",
            "export": "write the grid's settings and finished cells to --file (JSON, to keep with the code)",
            "import": "make a new grid of --file's settings and cells; the cells it lacks are queued"}



@dataclass(frozen=True)
class Cell:
    """One unit of work. Classical agents have no training: one cell per task, seed 0."""

    env: str
    agent: str
    hyperparameters: str
    seed: int

    @property
    def name(self) -> str:
        return f"{self.env}-{self.agent}-{self.hyperparameters}-{self.seed}"

    @property
    def trained(self) -> bool:
        return self.agent in ALGOS


def grid_cells(settings: dict[str, Any]) -> list[Cell]:
    """Classical cells first, then learners by expected cost (cheap tasks, PPO first)."""
    envs, algos = settings["envs"], settings["algos"]
    cells = [Cell(env, agent, "none", 0) for env in envs for agent in classical_agents(settings)
             if agent not in THREE_D_ONLY or env in RIGID3D_TASKS]
    for hyperparameters in ("tuned", "default"):
        cells += [Cell(env, algo, hyperparameters, seed) for env in envs for algo in algos
                  for seed in settings[f"{hyperparameters}_seeds"]]
    return cells


def classical_agents(settings: dict[str, Any]) -> tuple[str, ...]:
    """The grid's classical agents (:data:`CLASSICAL` in a grid made before ``--classical`` existed)."""
    return tuple(settings.get("classical", CLASSICAL))


def learner_choices(settings: dict[str, Any]) -> tuple[str, ...]:
    """The learners a grid's cells may name: :data:`LEARNERS` in a grid that asked for no other
    (every grid made before ``recurrent_ppo`` existed: Optuna refuses a parameter whose choices
    change within a study), else every algorithm."""
    return tuple(settings.get("learners", LEARNERS))


def cell_config(cell: Cell, settings: dict[str, Any]) -> dict[str, Any]:
    """train.py's configuration of a learner cell."""
    hp = load_hyperparams(cell.agent, cell.env)
    if cell.hyperparameters == "default":
        hp = {"n_timesteps": hp["n_timesteps"], "policy": hp.get("policy", policy_of(cell.agent))}
    if settings["timesteps"] is not None:
        hp["n_timesteps"] = settings["timesteps"]
    return {"algo": cell.agent, "env": cell.env, "seed": cell.seed, "vec_env": "batched",
            "eval_freq": settings["eval_freq"], "eval_episodes": settings["eval_episodes"],
            "save_freq": settings["save_freq"],
            "hyperparams_file": f"agents/hyperparams/{cell.agent}.yml" if cell.hyperparameters == "tuned"
            else "(library defaults)", "hyperparams": hp}


# ---------------------------------------------------------------------- storage
def storage_url(url: str) -> str:
    """``postgresql://`` means the psycopg (3) driver, the one this package installs."""
    return "postgresql+psycopg://" + url.removeprefix("postgresql://") if url.startswith("postgresql://") else url


def sqlite_file(url: str) -> Path | None:
    """The file of a ``sqlite:///FILE`` URL (None for other databases and in-memory SQLite)."""
    file = url.removeprefix("sqlite:///") if url.startswith("sqlite:///") else ""
    return Path(file) if file and file != ":memory:" else None


def open_storage(url: str, heartbeat: int, grace: int, create: bool = True, study: str = DEFAULT_STUDY) -> RDBStorage:
    """The grid's database; SQLite waits for its lock instead of failing at once.

    Without ``create`` a SQLite file that does not exist is refused (:class:`cli.UsageError`, naming
    the grid ``study`` looked for), so that looking (``status``, ``render``) leaves no empty database
    behind. A URL or database that cannot be opened is a one-line :class:`cli.UsageError` naming ``--storage``.
    """
    url = storage_url(url)
    file = sqlite_file(url)
    if file is not None and not create and not file.is_file():
        raise cli.UsageError(f"--storage {url}: no grid {study!r} yet ({file} does not exist): "
                             f"python -m agents.grid run --study {study} creates it")
    if file is not None and create:
        cli.check_writable_dir(file.parent, "--storage")
        file.parent.mkdir(parents=True, exist_ok=True)
    try:
        return _connect(url, heartbeat, grace)
    except SQLAlchemyError as err:  # a bogus URL, a file that is not a database, a server that refuses
        first = str(getattr(err, "orig", None) or err).splitlines()[0]
        raise cli.UsageError(f"--storage {url}: cannot open it ({type(err).__name__}: {first})") from err


def _connect(url: str, heartbeat: int, grace: int) -> RDBStorage:
    engine = {"connect_args": {"timeout": 60}} if url.startswith("sqlite") else {"pool_pre_ping": True}
    def connect() -> RDBStorage:
        return RDBStorage(url, engine_kwargs=engine, heartbeat_interval=heartbeat, grace_period=grace,
                          heartbeat_stale_trial_callback=RetryHeartbeatStaleTrialCallback(max_retry=MAX_RETRY))

    for attempt in range(SCHEMA_ATTEMPTS - 1):
        try:
            return connect()
        except (IntegrityError, ProgrammingError, OperationalError):
            # Workers creating the schema of a new database at once: one wins, the others read
            # "already exists" and try again; a storage that stays unreachable fails on the last try.
            time.sleep(1 + attempt)
    return connect()


def load_grid(storage: RDBStorage, study_name: str) -> optuna.Study:
    """The grid ``study_name``; a one-line error that says how to make it if there is none."""
    try:
        return optuna.load_study(storage=storage, study_name=study_name)
    except KeyError:
        names = [s.study_name for s in optuna.get_all_study_summaries(storage, include_best_trial=False)]
        raise cli.UsageError(f"--study {study_name}: no such grid in the storage (it has {names or 'none'}): "
                             f"python -m agents.grid run --study {study_name} creates it") from None


def create_grid(storage: RDBStorage, study_name: str, cells: list[Cell], settings: dict[str, Any]) -> optuna.Study:
    """The grid's study. Only the worker that creates it enqueues the cells, so two workers
    starting at once never enqueue a cell twice; the others wait until the grid is complete."""
    try:
        study = optuna.create_study(storage=storage, study_name=study_name, direction="maximize")
    except optuna.exceptions.DuplicatedStudyError:
        study = optuna.load_study(storage=storage, study_name=study_name)
        deadline = time.monotonic() + 120
        while "settings" not in study.user_attrs:
            if time.monotonic() > deadline:
                raise RuntimeError(f"study {study_name!r} exists but holds no grid (not made by agents.grid?)")
            time.sleep(1)
        if study.user_attrs["settings"] != settings:
            raise ValueError(f"study {study_name!r} was made with {study.user_attrs['settings']}, "
                             f"not {settings}: use another --study")
        return study
    for cell in cells:
        enqueue(study, cell)
    study.set_user_attr("settings", settings)
    return study


def enqueue(study: optuna.Study, cell: Cell) -> None:
    study.enqueue_trial({"env": cell.env, "agent": cell.agent, "hyperparameters": cell.hyperparameters,
                         "seed": cell.seed}, user_attrs={"cell": cell.name})


def export_grid(study: optuna.Study, path: Path) -> int:
    """``export``: the grid's settings and its cells' finished trials into ``path``; returns how many."""
    trials = kept.kept_trials(study)
    trials["trials"] = [t for t in trials["trials"] if t["user_attrs"].get("cell")]  # not a stray ask (claim)
    kept.write(path, trials)
    return len(trials["trials"])


def import_grid(storage: RDBStorage, study_name: str, trials: dict[str, Any]) -> tuple[int, int]:
    """``import``: a new grid of the kept ``trials``' settings and cells, the cells they lack queued
    (a grid already in the storage is refused: its queue may hold the same cells). Returns how
    many cells were imported and how many queued."""
    if study_name in (s.study_name for s in optuna.get_all_study_summaries(storage, include_best_trial=False)):
        raise cli.UsageError(f"import: the storage already has a grid {study_name!r}; import makes a new one")
    settings = trials["user_attrs"]["settings"]
    study = optuna.create_study(storage=storage, study_name=study_name, direction="maximize")
    added = kept.add_trials(study, trials)
    finished = {cell_of(t) for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))}
    waiting = [cell for cell in grid_cells(settings) if cell not in finished]
    for cell in waiting:
        enqueue(study, cell)
    study.set_user_attr("settings", settings)  # last: a worker starting meanwhile waits for it (create_grid)
    return added, len(waiting)


def redo(study: optuna.Study, agents: list[str], envs: list[str]) -> list[Cell]:
    """Queue the finished (or failed) cells of ``agents`` on ``envs`` again, e.g. after the agent's
    code changed. The new trial replaces the old one in ``status`` and the table once it is done;
    a learner's cell finds its finished run and only plays its episodes again."""
    cells = [cell for cell, trial in cell_trials(study).items()
             if cell.agent in agents and cell.env in envs and trial.state in (TrialState.COMPLETE, TrialState.FAIL)]
    for cell in cells:
        enqueue(study, cell)
    return cells


def suggest_cell(trial: optuna.Trial, settings: dict[str, Any]) -> Cell:
    """The cell a queued trial stands for (its params are fixed when enqueued)."""
    agents = (*classical_agents(settings), *learner_choices(settings))  # the choices a grid was made with
    return Cell(trial.suggest_categorical("env", settings["envs"]), trial.suggest_categorical("agent", agents),
                trial.suggest_categorical("hyperparameters", ["none", *HYPERPARAMETERS]),
                trial.suggest_int("seed", 0, max(settings["tuned_seeds"] + settings["default_seeds"] + [0])))


def claim(storage: RDBStorage, study: optuna.Study) -> optuna.Trial | None:
    """The next waiting cell, now ours; None if no cell is waiting."""
    while True:
        try:
            fail_stale_trials(study)  # dead workers' cells go back to the queue
            if not study.get_trials(deepcopy=False, states=(TrialState.WAITING,)):
                return None
            trial = study.ask()
        except OperationalError:  # SQLite: another worker holds the lock
            time.sleep(0.5)
            continue
        if "fixed_params" in storage.get_trial(trial._trial_id).system_attrs:
            return trial
        # Another worker took the last waiting cell between our look and our ask: ask() made
        # a fresh trial that stands for no cell. Mark it so and look again.
        trial.set_user_attr("cell", None)
        study.tell(trial, state=TrialState.PRUNED)


@contextmanager
def cell_lock(run_dir: Path, name: str) -> Iterator[None]:
    """Hold the cell's lock file (beside its run folder) while the block runs: a second trial of a
    cell whose worker still runs it waits here instead of training into the same folder. The
    kernel drops the lock of a process that dies, so a dead worker's cell is not blocked."""
    lock = run_dir.with_name(f".{run_dir.name}.lock")
    lock.parent.mkdir(parents=True, exist_ok=True)
    with lock.open("a") as file:
        try:
            fcntl.flock(file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            print(f"{name}: another worker still runs this cell; waiting for it to stop", flush=True)
            fcntl.flock(file, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(file, fcntl.LOCK_UN)


def owns(storage: RDBStorage, trial: optuna.Trial) -> bool:
    """Whether the trial is still this worker's: running, not failed as stale by another worker."""
    return storage.get_trial(trial._trial_id).state == TrialState.RUNNING


def record(storage: RDBStorage, study: optuna.Study, trial: optuna.Trial, result: dict[str, Any]) -> bool:
    """Store a cell's result in its trial and finish it; False if the trial was taken meanwhile."""
    try:
        if not owns(storage, trial):
            return False
        for key, value in result.items():
            trial.set_user_attr(key, value)
        study.tell(trial, result["summary"]["success_rate"])
    except UpdateFinishedTrialError:  # taken between the look and the writes
        return False
    return True


@contextmanager
def beating(storage: RDBStorage, trial: optuna.Trial) -> Iterator[None]:
    """Record the trial's heartbeat every interval while the block runs."""
    stop = threading.Event()

    def beat() -> None:
        while not stop.wait(storage.get_heartbeat_interval()):
            storage.record_heartbeat(trial._trial_id)

    storage.record_heartbeat(trial._trial_id)
    thread = threading.Thread(target=beat, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


# ---------------------------------------------------------------------- one cell
def play(cell: Cell, run_dir: Path) -> dict[str, Any]:
    """The cell's agent on the grid's ``EPISODES`` paired episodes (evaluate.py's default seed)."""
    if cell.trained:
        model = run_dir / "best_model.zip"
        agent_spec = str(model if model.is_file() else run_dir / "final_model.zip")
    else:
        agent_spec = cell.agent
    env = gym.make(cell.env)
    agent = evaluation.make_agent(agent_spec, env)
    env.close()
    episodes = evaluation.run_batch(cell.env, agent, EPISODES, evaluation.DEFAULT_SEED)
    # Each episode's outcome too: the table pairs every row with LQG's on the same episodes.
    return {**evaluation.summarise(episodes), "successes": [int(e["success"]) for e in episodes]}


def run_cell(cell: Cell, trial: optuna.Trial, run_dir: Path, settings: dict[str, Any]) -> dict[str, Any]:
    """Train (resuming from the newest checkpoint if there is one), evaluate; the results."""
    started = time.perf_counter()
    result: dict[str, Any] = {"versions": versions(), "run_dir": str(run_dir)}
    if cell.trained:
        config = cell_config(cell, settings)
        result["hyperparams"] = config["hyperparams"]
        try:  # a cell put back in the queue continues from its newest checkpoint that loads
            reached = training.checkpoint_steps(training.resumable_checkpoint(run_dir, config["hyperparams"]))
        except ModelLoadError:  # none (a worker killed while writing its first one): start afresh
            reached = None
        resume, done = reached is not None, reached is not None and reached >= int(config["hyperparams"]["n_timesteps"])
        if not done:
            session = training.train(config, run_dir, f"python -m agents.grid run ({cell.name})", resume=resume,
                                     on_evaluation=lambda steps, rate: trial.set_user_attr("timesteps", steps))
            if session["status"] != "finished":
                raise KeyboardInterrupt(session["status"])
        record = training.read_run(run_dir)
        # The learning curve as the trial's intermediate values: the export keeps it when runs/ is gone
        # (benchmarks.learning_curves --grid draws it), and Optuna's dashboard plots it.
        for steps, rate in training.selection_history(run_dir):
            trial.report(rate, steps)
        result["timesteps"] = record["sessions"][-1]["timesteps"]
        result["wall_time_s"] = sum(s.get("wall_time_s", 0.0) for s in record["sessions"])
    result["summary"] = play(cell, run_dir)
    result["cell_wall_time_s"] = time.perf_counter() - started
    return result


# ---------------------------------------------------------------------- the worker
def work(storage: RDBStorage, study: optuna.Study, runs_dir: Path, max_cells: int | None, wait: bool) -> int:
    """Take cells until none is waiting (and, with ``wait``, none is running elsewhere)."""
    settings, done = study.user_attrs["settings"], 0
    while (max_cells is None or done < max_cells) and training.stop_requested() is None:
        trial = claim(storage, study)
        if trial is None:
            running = study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))
            if wait and running:  # a running cell may yet come back if its worker dies
                time.sleep(storage.get_heartbeat_interval())
                continue
            break
        cell = suggest_cell(trial, settings)
        trial.set_user_attr("worker", WORKER)
        run_dir = runs_dir / study.study_name / cell.name
        print(f"[{time.strftime('%H:%M:%S')}] {cell.name}: started (trial {trial.number}) -> {run_dir}", flush=True)
        # A trial failed as stale while its worker lives (heartbeats late) is queued again: the
        # second trial waits on the cell's lock; the first worker stops at its next evaluation
        # (setting an attribute of a finished trial raises) and records nothing.
        try:
            with beating(storage, trial), cell_lock(run_dir, cell.name):
                result = run_cell(cell, trial, run_dir, settings)
        except KeyboardInterrupt:
            if owns(storage, trial):
                study.tell(trial, state=TrialState.FAIL)
                storage.get_heartbeat_stale_trial_callback()(study, study.get_trials(deepcopy=False)[trial.number])
            print(f"{cell.name}: stopped; put back in the queue (resumes from its checkpoint)", flush=True)
            return 130
        except UpdateFinishedTrialError:
            result = None
        except Exception as err:  # noqa: BLE001  (one broken cell must not stop the grid)
            result = None
            if owns(storage, trial):
                trial.set_user_attr("error", f"{type(err).__name__}: {err}")
                study.tell(trial, state=TrialState.FAIL)
                print(f"{cell.name}: FAILED ({type(err).__name__}: {err})", flush=True)
                continue
        if result is None or not record(storage, study, trial, result):
            print(f"{cell.name}: its trial {trial.number} was handed to another worker (heartbeats later than "
                  "--grace); that worker records the cell", flush=True)
            continue
        done += 1
        summary = result["summary"]
        print(f"[{time.strftime('%H:%M:%S')}] {cell.name}: success {summary['success_rate']:.1%}, median pointing "
              f"{evaluation.fmt_rad(summary['terminal_pointing_rad']['median'])}", flush=True)
    return 0


# ---------------------------------------------------------------------- status and table
def cell_of(trial: FrozenTrial) -> Cell:
    """The cell of a trial, also before its worker has read its parameters."""
    params = trial.params or trial.system_attrs["fixed_params"]
    return Cell(*(params[key] for key in CELL_PARAMS))


def cell_trials(study: optuna.Study) -> dict[Cell, FrozenTrial]:
    """The latest trial of each cell (a cell put back in the queue has several)."""
    return {cell_of(trial): trial for trial in study.get_trials(deepcopy=False) if trial.user_attrs.get("cell")}


def status_text(study: optuna.Study) -> str:
    """Counts by state, the running and failed cells, and an estimate of the time that remains."""
    trials = cell_trials(study)
    by_state: dict[str, list[tuple[Cell, FrozenTrial]]] = defaultdict(list)
    for cell, trial in trials.items():
        by_state[trial.state.name].append((cell, trial))
    lines = [f"study {study.study_name}: {len(trials)} cells, "
             + ", ".join(f"{len(v)} {k.lower()}" for k, v in sorted(by_state.items()))]
    for cell, trial in by_state.get("RUNNING", []):
        elapsed = time.time() - trial.datetime_start.timestamp()
        lines.append(f"  running  {cell.name} on {trial.user_attrs.get('worker', '?')} for {elapsed / 60:.0f} min, "
                     f"{trial.user_attrs.get('timesteps', 0):,} steps at its last evaluation")
    for cell, trial in by_state.get("FAIL", []):
        lines.append(f"  failed   {cell.name}: {trial.user_attrs.get('error', 'worker stopped')}")
    if len(by_state.get("COMPLETE", [])) == len(trials):
        return "\n".join([*lines, "all cells done: python -m agents.grid render"])
    remaining = remaining_seconds(study, trials)
    workers = max(1, len(by_state.get("RUNNING", [])))
    if remaining is None:
        lines.append("remaining: no estimate until one cell of each learner has finished")
    else:
        lines.append(f"remaining: about {remaining / 3600:.1f} h of one worker's time "
                     f"({remaining / 3600 / workers:.1f} h with {workers} worker{'s' * (workers > 1)})")
    return "\n".join(lines)


def remaining_seconds(study: optuna.Study, trials: dict[Cell, FrozenTrial]) -> float | None:
    """Training steps left × seconds per step measured on finished cells of the same learner
    (and task, when one has finished)."""
    per_step: dict[tuple[str, str | None], list[float]] = defaultdict(list)
    for cell, trial in trials.items():
        if cell.trained and trial.state == TrialState.COMPLETE:
            rate = trial.user_attrs["wall_time_s"] / trial.user_attrs["timesteps"]
            per_step[(cell.agent, cell.env)].append(rate)
            per_step[(cell.agent, None)].append(rate)
    timesteps, total = study.user_attrs["settings"]["timesteps"], 0.0
    for cell, trial in trials.items():
        if not cell.trained or trial.state == TrialState.COMPLETE:
            continue
        rates = per_step.get((cell.agent, cell.env)) or per_step.get((cell.agent, None))
        if not rates:
            return None
        steps = timesteps or load_hyperparams(cell.agent, cell.env)["n_timesteps"]
        total += float(np.median(rates)) * max(steps - trial.user_attrs.get("timesteps", 0), 0)
    return total


def log10(value: float | None) -> float:
    return math.log10(value) if value else math.inf


def table_markdown(study: optuna.Study) -> str:
    """Per task: each agent's success rate (mean ± std over seeds); its paired difference to LQG on
    the same episodes (a learner's seeds averaged per episode) with a 95 % bootstrap interval; how far
    it lies below the ceiling (the best of the bounds :data:`CEILING` in the grid); median and p90
    pointing; training steps and time."""
    groups: dict[tuple[str, str, str], list[FrozenTrial]] = defaultdict(list)
    for cell, trial in cell_trials(study).items():
        if trial.state == TrialState.COMPLETE:
            groups[(cell.env, cell.agent, cell.hyperparameters)].append(trial)
    settings = study.user_attrs["settings"]
    lines = ["| task | agent | hyperparameters | seeds | success (mean ± std) | vs LQG (paired, 95 % CI) | "
             "below the ceiling | log10 median pointing | log10 p90 pointing | training steps | "
             "training time per seed |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for env in dict.fromkeys(settings["envs"]):  # once each, also in a grid made when repeats were accepted
        reference = _successes(groups.get((env, REFERENCE, "none"), []))
        bounds = [np.mean([t.user_attrs["summary"]["success_rate"] for t in groups[(env, agent, "none")]])
                  for agent in CEILING if (env, agent, "none") in groups]
        ceiling = max(bounds) if bounds else None
        for agent in ROW_ORDER:
            for hyperparameters in ("none", *HYPERPARAMETERS):
                trials = groups.get((env, agent, hyperparameters))
                if not trials:
                    continue
                summaries = [t.user_attrs["summary"] for t in trials]
                success = np.array([s["success_rate"] for s in summaries])
                median = np.array([log10(s["terminal_pointing_rad"]["median"]) for s in summaries])
                p90 = np.array([log10(s["terminal_pointing_rad"]["p90"]) for s in summaries])
                expected = len(settings[f"{hyperparameters}_seeds"]) if agent in ALGOS else 1
                spread = f" ± {100 * success.std():.1f}" if len(trials) > 1 else ""
                steps = f"{int(np.mean([t.user_attrs['timesteps'] for t in trials])):,}" if agent in ALGOS else "–"
                wall = f"{np.mean([t.user_attrs['wall_time_s'] for t in trials]) / 60:.1f} min" if agent in ALGOS else "–"
                label = "–" if hyperparameters == "none" else hyperparameters
                name = f"{agent} (a bound)" if agent in CEILING else agent
                versus, own = "–", _successes(trials)
                if reference is not None and own is not None and agent != REFERENCE:
                    d = evaluation.paired_difference(own, reference[0])
                    versus = f"{100 * d['difference']:+.1f} pts ({100 * d['ci95'][0]:+.1f} … {100 * d['ci95'][1]:+.1f})"
                below = f"{100 * (ceiling - success.mean()):.1f} pts" if ceiling is not None and agent not in CEILING else "–"
                lines.append(f"| {env} | {name} | {label} | {len(trials)}/{expected} | {100 * success.mean():.1f} %"
                             f"{spread} | {versus} | {below} | {median.mean():.2f} | {p90.mean():.2f} | {steps} | "
                             f"{wall} |")
    return "\n".join(lines)


def _successes(trials: list[FrozenTrial]) -> np.ndarray | None:
    """Each trial's per-episode outcomes (trials, episodes), or None if a trial predates them."""
    if not trials or any("successes" not in t.user_attrs["summary"] for t in trials):
        return None
    return np.array([t.user_attrs["summary"]["successes"] for t in trials], bool)


#: The README section the grid's table goes into (``render --readme``) unless ``--section`` names another.
README_SECTION = "grid-table"
README_START, README_END = cli.section_markers(README_SECTION)


# ---------------------------------------------------------------------- command line
def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The arguments, checked: :class:`cli.UsageError` (one line) for any that cannot be right."""
    commands = "\n".join(f"  {name:<8}{text}" for name, text in COMMANDS.items())
    parser = cli.Parser(prog="python -m agents.grid", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter, epilog=f"commands:\n{commands}")
    parser.add_argument("command", choices=COMMANDS, metavar="COMMAND", help=f"{', '.join(COMMANDS)} (see below)")
    parser.add_argument("--storage", default=DEFAULT_STORAGE, help="SQLAlchemy URL (sqlite:///FILE, postgresql://…)")
    parser.add_argument("--study", default=DEFAULT_STUDY, help="name of the grid in the storage")
    parser.add_argument("--runs-dir", type=Path, default=Path("runs/grid"), help="where cells keep their files")
    parser.add_argument("--envs", nargs="+", default=list(PLANAR_TASKS), choices=list(TASKS), metavar="ID",
                        help="tasks of the grid")
    parser.add_argument("--algos", nargs="+", default=list(LEARNERS), choices=sorted(ALGOS), help="learners of the grid")
    parser.add_argument("--seeds", nargs="+", type=cli.non_negative_int, default=list(SEEDS), help="seeds of the tuned rows")
    parser.add_argument("--default-seeds", nargs="*", type=cli.non_negative_int, default=[0],
                        help="seeds of the library-defaults rows (none: no such rows)")
    parser.add_argument("--timesteps", type=cli.positive_int,
                        help="override every learner's budget (tests; default: each one's shipped n_timesteps)")
    parser.add_argument("--eval-freq", type=int, default=10_000,
                        help="training-time evaluations (model selection) every N steps (<= 0: never)")
    parser.add_argument("--eval-episodes", type=cli.positive_int, default=100, help="episodes per training-time evaluation")
    parser.add_argument("--save-freq", type=cli.positive_int, default=training.DEFAULT_SAVE_FREQ,
                        help="checkpoint every N steps")
    parser.add_argument("--max-cells", type=cli.positive_int, help="stop after this many cells")
    parser.add_argument("--no-wait", action="store_true", help="exit when no cell is waiting, even if some run elsewhere")
    parser.add_argument("--heartbeat", type=cli.positive_int, default=60, help="seconds between heartbeats")
    parser.add_argument("--grace", type=cli.positive_int, default=300,
                        help=f"seconds without a heartbeat after which a cell is taken again (at least "
                             f"{GRACE_HEARTBEATS} × --heartbeat)")
    parser.add_argument("--agents", nargs="+", default=[], choices=AGENTS, metavar="AGENT",
                        help=f"redo: the agents whose cells to queue again (on --envs): {', '.join(AGENTS)}")
    parser.add_argument("--readme", type=Path, help="render: write the table into this file's --section markers")
    parser.add_argument("--section", default=README_SECTION,
                        help="render: the markers' name (<!-- NAME:start --> … <!-- NAME:end -->)")
    parser.add_argument("--file", type=Path, help="export: the file to write; import: the file to read")
    parser.add_argument("--classical", nargs="+", default=list(CLASSICAL), choices=list(evaluation.BASELINES),
                        metavar="AGENT", help=f"run: the classical rows ({', '.join(evaluation.BASELINES)}; "
                                              f"{' and '.join(sorted(THREE_D_ONLY))} on the 3D tasks only; "
                                              f"lqr-oracle and lqg-oracle are bounds)")
    args = parser.parse_args(argv)
    for flag in ("envs", "algos", "seeds", "default_seeds", "agents", "classical"):
        cli.distinct(getattr(args, flag), f"--{flag.replace('_', '-')}")
    if args.grace < GRACE_HEARTBEATS * args.heartbeat:
        parser.error(f"argument --grace: must be at least {GRACE_HEARTBEATS} × --heartbeat ({args.heartbeat} s), "
                     f"got {args.grace}: a live worker's cell would be handed to a second worker")
    if args.readme is not None:
        cli.readme_around_section(args.readme, args.section)
    if args.command in ("export", "import") and args.file is None:
        parser.error(f"{args.command} needs --file")
    if args.command == "export":
        cli.check_writable_dir(args.file.parent, "--file")
        if args.file.is_dir():
            parser.error(f"--file {args.file} is a directory")
    return args


def main(argv: list[str] | None = None) -> int:
    # Heartbeats outside Study.optimize and fail_stale_trials are marked experimental.
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    warnings.filterwarnings("ignore", message="Heartbeat of storage is supposed to be used with Study.optimize")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    try:
        args = parse_args(argv)
        settings = {"envs": args.envs, "algos": args.algos, "tuned_seeds": args.seeds,
                    "default_seeds": args.default_seeds, "timesteps": args.timesteps, "eval_freq": args.eval_freq,
                    "eval_episodes": args.eval_episodes, "save_freq": args.save_freq, "episodes": EPISODES}
        if args.classical != list(CLASSICAL):  # absent otherwise: a grid made before --classical still opens
            settings["classical"] = args.classical
        if not set(args.algos) <= set(LEARNERS):  # absent otherwise, as "classical"
            settings["learners"] = sorted(ALGOS)
        trials = kept.read(args.file, args.study, "--file") if args.command == "import" else None
        if trials is not None and not isinstance(trials.get("user_attrs", {}).get("settings"), dict):
            raise cli.UsageError(f"--file {args.file}: no grid settings (a tuning study's export?)")
        storage = open_storage(args.storage, args.heartbeat, args.grace, create=args.command in ("run", "import"),
                               study=args.study)
        if args.command == "import":
            added, waiting = import_grid(storage, args.study, trials)
            print(f"grid {args.study}: {added} finished cells imported, {waiting} queued")
            return 0
        if args.command == "run":
            study = create_grid(storage, args.study, grid_cells(settings), settings)
            with training.stopping_on_signals():
                return work(storage, study, args.runs_dir, args.max_cells, wait=not args.no_wait)
        study = load_grid(storage, args.study)
    except (ValueError, KeyError, RuntimeError, SQLAlchemyError) as err:  # cli.UsageError is a ValueError
        return cli.fail(str(err).splitlines()[0])
    if args.command == "status":
        print(status_text(study))
    elif args.command == "redo":
        cells = redo(study, args.agents, args.envs)
        print(f"queued again: {', '.join(c.name for c in cells) or 'nothing'}")
    elif args.command == "export":
        print(f"grid {args.study}: {export_grid(study, args.file)} finished cells -> {args.file}")
    else:
        table = table_markdown(study)
        if args.readme is not None:
            cli.replace_readme_section(args.readme, args.section, table)
        print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
