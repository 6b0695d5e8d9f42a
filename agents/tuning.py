"""Hyperparameter search for any algorithm and task: Optuna's TPE sampler and median pruner on
the success rate of train.py's periodic evaluations, in the grid's storage.

    python -m agents.tuning --algo sac --env LightSailDeepDish-v0 --trials 40
    python -m agents.tuning --algo ppo --env LightSailUncertain-v1 --residual lqg-mm   # corrections of lqg-mm
    python train.py --algo sac --env LightSailDeepDish-v0 --config runs/tuning/<study>/best.yml

A study's finished trials (parameters, scores, the evaluations the pruner compares) can be kept
with the code, where a fresh checkout finds them (``runs/`` is not versioned):

    python -m agents.tuning --algo sac --env LightSailRealistic-v0 --export benchmarks/results/tuning/tune-sac-LightSailRealistic-v0.json
    python -m agents.tuning --algo sac --env LightSailRealistic-v0 --import benchmarks/results/tuning/tune-sac-LightSailRealistic-v0.json

A configuration worth trying first (a neighbour task's best, say) is queued with ``--enqueue``: the
next worker trains it as the study's next trial, and the sampler sees its score as any other's:

    python -m agents.tuning --algo sac --env LightSail3DRealistic-v1 --enqueue train_freq=4 learning_rate=3.77e-5 \\
        batch_size=512 buffer_size=100000 learning_starts=100 gamma=0.995 tau=0.02 net_arch=medium activation_fn=tanh

``--export`` writes them and stops; ``--import`` adds those the storage lacks (:mod:`agents.kept`)
and stops (once, before the workers start: two imports at once would each add every trial); the
search then goes on with the sampler and the pruner seeing them as the study's own.

Each trial is a train.py run (``runs/tuning/<study>/trial-<N>``, numbered ``_2``, … if another
study of that name, in another storage, left one there) whose evaluations report the
success rate to Optuna; a trial below the median of earlier trials at the same step is
pruned. ``--trials`` counts finished trials over every worker: start the same command on more
machines with ``--storage postgresql://…`` to search in parallel. The best trial is written as a
Zoo-style YAML entry that ``train.py --config`` reads.

Why not RL Baselines3 Zoo's ``--optimize``: it ranks trials by mean return through its own env
wrappers; this task is judged by the success rate, measured on train.py's paired evaluation
episodes with the batched env. The sampler, pruner and storage are Optuna's own.
"""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path
from collections.abc import Callable
from typing import Any

import optuna
import yaml
from optuna.study import MaxTrialsCallback
from optuna.storages import RDBStorage
from optuna.trial import FrozenTrial, TrialState

from agents import cli, grid, kept, training
from agents.residual import RESIDUAL_BASES
from agents.sb3 import ALGOS, ModelLoadError, load_hyperparams, policy_of
from sail_env.tasks import TASKS

ACTIVATIONS = {"tanh": "nn.Tanh", "relu": "nn.ReLU"}
NET_ARCHS = {"small": [64, 64], "medium": [256, 256]}


def sample_ppo(trial: optuna.Trial, stack: bool = True) -> dict[str, Any]:
    """PPO's usual search space (as in the Zoo's), with 8 batched envs (a history when ``stack``)."""
    n_steps = trial.suggest_categorical("n_steps", [64, 128, 256, 512, 1024])
    log_std = trial.suggest_float("log_std_init", -3.0, 0.0)
    return {"n_envs": 8, "n_steps": n_steps,
            "batch_size": trial.suggest_categorical("batch_size", [64, 128, 256]),
            "n_epochs": trial.suggest_categorical("n_epochs", [5, 10, 20]),
            "learning_rate": trial.suggest_float("learning_rate", 1e-5, 3e-3, log=True),
            "gamma": trial.suggest_categorical("gamma", [0.98, 0.99, 0.995, 0.999]),
            "gae_lambda": trial.suggest_categorical("gae_lambda", [0.9, 0.95, 0.98]),
            "clip_range": trial.suggest_categorical("clip_range", [0.1, 0.2, 0.3]),
            "ent_coef": trial.suggest_float("ent_coef", 1e-8, 1e-2, log=True),
            "normalize": True, "frame_stack": history(trial) if stack else 1,
            "policy_kwargs": network(trial, f", log_std_init={log_std:.3f}")}


def sample_recurrent_ppo(trial: optuna.Trial) -> dict[str, Any]:
    """PPO's space with an LSTM in place of the stacked history: its hidden size, whether the critic
    has its own LSTM (sb3-contrib's ``RecurrentPPO``)."""
    hp = sample_ppo(trial, stack=False)
    hidden = trial.suggest_categorical("lstm_hidden_size", [32, 64, 128, 256])
    critic = trial.suggest_categorical("enable_critic_lstm", [True, False])
    hp["policy_kwargs"] = hp["policy_kwargs"][:-1] + f", lstm_hidden_size={hidden}, enable_critic_lstm={critic})"
    return hp


def sample_off_policy(trial: optuna.Trial) -> dict[str, Any]:
    """SAC's and TD3's shared search space (one env, normalised observations; no history: with
    normalisation their replay buffer cannot hold a stack, :func:`agents.training.check_hyperparams`)."""
    train_freq = trial.suggest_categorical("train_freq", [1, 4, 8, 16])
    return {"n_envs": 1, "normalize": "dict(norm_obs=True, norm_reward=False)",
            "learning_rate": trial.suggest_float("learning_rate", 1e-5, 3e-3, log=True),
            "batch_size": trial.suggest_categorical("batch_size", [64, 128, 256, 512]),
            "buffer_size": trial.suggest_categorical("buffer_size", [10_000, 100_000, 300_000]),
            "learning_starts": trial.suggest_categorical("learning_starts", [100, 1000, 5000]),
            "gamma": trial.suggest_categorical("gamma", [0.98, 0.99, 0.995, 0.999]),
            "tau": trial.suggest_categorical("tau", [0.005, 0.01, 0.02, 0.05]),
            "train_freq": train_freq, "gradient_steps": train_freq,
            "policy_kwargs": network(trial, "")}


def sample_td3(trial: optuna.Trial) -> dict[str, Any]:
    return {**sample_off_policy(trial), "noise_type": "normal",
            "noise_std": trial.suggest_float("noise_std", 0.01, 0.5, log=True)}


SAMPLERS = {"ppo": sample_ppo, "recurrent_ppo": sample_recurrent_ppo, "sac": sample_off_policy, "td3": sample_td3}


def history(trial: optuna.Trial) -> int:
    """Observations the policy sees side by side (``frame_stack``; 1: the newest alone): a history
    lets the policy average delayed, noisy observations, as the LQG's Kalman filter does."""
    return trial.suggest_categorical("frame_stack", [1, 2, 4, 8])


def residual(trial: optuna.Trial, base: str | None) -> dict[str, Any]:
    """A residual policy's keys (agents/residual.py): the base controller, the correction's size."""
    if base is None:
        return {}
    return {"residual": base, "residual_scale": trial.suggest_float("residual_scale", 0.05, 1.0, log=True)}


def network(trial: optuna.Trial, extra: str) -> str:
    """``policy_kwargs`` in the Zoo's string form, which train.py's YAML reader accepts."""
    arch = NET_ARCHS[trial.suggest_categorical("net_arch", sorted(NET_ARCHS))]
    activation = ACTIVATIONS[trial.suggest_categorical("activation_fn", sorted(ACTIVATIONS))]
    return f"dict(net_arch={arch}, activation_fn={activation}{extra})"


def trial_config(trial: optuna.Trial, algo: str, env_id: str, settings: dict[str, Any]) -> dict[str, Any]:
    """train.py's configuration of one trial. A retried trial trains its original's hyperparameters
    (inherited with its user attributes), not a new draw: a search space widened since (as by
    ``frame_stack``) would otherwise add a drawn value and train another configuration."""
    hp = trial.user_attrs.get("hyperparams") or {"policy": policy_of(algo), "n_timesteps": settings["timesteps"],
                                                  **SAMPLERS[algo](trial), **residual(trial, settings.get("residual"))}
    return {"algo": algo, "env": env_id, "seed": settings["seed"], "vec_env": "batched",
            "eval_freq": settings["eval_freq"], "eval_episodes": settings["eval_episodes"],
            "save_freq": settings["eval_freq"], "hyperparams_file": f"(optuna trial {trial.number})",
            "hyperparams": hp}


def objective(algo: str, env_id: str, settings: dict[str, Any], runs_dir: Path,
              retry: Callable[[optuna.Study, FrozenTrial], None]):
    """The objective: train one sampled configuration; its best evaluation success rate.

    A trial stopped by a signal, or failed as stale when its worker died, is queued again with
    its parameters and folder (the storage's retry callback), and the retry resumes that
    folder's newest checkpoint instead of starting over.
    """
    def run(trial: optuna.Trial) -> float:
        config = trial_config(trial, algo, env_id, settings)
        trial.set_user_attr("hyperparams", config["hyperparams"])

        def report(timesteps: int, success_rate: float) -> None:
            trial.report(success_rate, timesteps)
            if trial.should_prune():
                raise optuna.TrialPruned(f"success {success_rate:.1%} at {timesteps} steps")

        run_dir, checkpoint = retried_folder(trial, config)
        if checkpoint is not None and training.resume_point(run_dir, config, checkpoint) >= training.whole_rollouts(
                algo, settings["timesteps"], config["hyperparams"]):
            return training.read_best(run_dir)["success_rate"]  # it had finished when its worker died
        if run_dir is None:
            # A fresh folder: one left by another study of this name (in another storage) holds its
            # best_model.json, which this trial would read as its own score.
            run_dir = training.fresh_dir(runs_dir / f"trial-{trial.number}")
        trial.set_user_attr("run_dir", str(run_dir))
        session = training.train(config, run_dir, f"python -m agents.tuning (trial {trial.number})",
                                 resume=checkpoint is not None, on_evaluation=report)
        if session["status"] != "finished":  # stopped by a signal: queue it again, then stop
            retry(trial.study, trial.study.get_trials(deepcopy=False)[trial.number])
            raise KeyboardInterrupt(session["status"])
        return training.read_best(run_dir)["success_rate"]
    return run


def retried_folder(trial: optuna.Trial, config: dict[str, Any]) -> tuple[Path | None, Path | None]:
    """The folder a retried trial continues (its original's, inherited with its user attributes)
    and the checkpoint it resumes from (None: start the folder afresh); (None, None) for a new trial."""
    inherited = trial.user_attrs.get("run_dir")
    if inherited is None or not Path(inherited).is_dir():
        return None, None
    try:
        return Path(inherited), training.resumable_checkpoint(Path(inherited), config["hyperparams"])
    except ModelLoadError:  # killed before its first checkpoint
        return training.fresh_dir(Path(inherited)), None


def configuration(algo: str, base: str | None, assignments: list[str]) -> dict[str, Any]:
    """A trial's parameters from ``KEY=VALUE`` items, one for every parameter of the search space
    (values read as YAML: ``4``, ``3.77e-5``, ``tanh``), checked whole against the space."""
    params: dict[str, Any] = {}
    for item in assignments:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise cli.UsageError(f"--enqueue {item!r}: expected KEY=VALUE")
        params[key] = yaml.safe_load(value)
    verbosity = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # no "study created" line on stderr
    try:
        drawn = optuna.create_study().ask()  # in memory: one draw names every parameter of the space
    finally:
        optuna.logging.set_verbosity(verbosity)
    SAMPLERS[algo](drawn)
    residual(drawn, base)
    for key, distribution in drawn.distributions.items():
        if key in params:
            params[key] = typed(key, params[key], distribution)
    missing, unknown = sorted(set(drawn.params) - set(params)), sorted(set(params) - set(drawn.params))
    if missing or unknown:
        raise cli.UsageError(f"--enqueue: {algo}'s search space is {', '.join(sorted(drawn.params))}"
                             + (f"; missing: {', '.join(missing)}" if missing else "")
                             + (f"; not in it: {', '.join(unknown)}" if unknown else ""))
    fixed = optuna.trial.FixedTrial(params)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # a value outside a float range: Optuna only warns
        try:
            SAMPLERS[algo](fixed)
            residual(fixed, base)
        except (ValueError, UserWarning) as err:
            raise cli.UsageError(f"--enqueue: {err}") from err
    return params


def typed(key: str, value: Any, distribution: optuna.distributions.BaseDistribution) -> Any:
    """``value`` of an ``--enqueue`` item as the number its parameter's range takes. YAML 1.1 reads
    ``3e-4`` (no dot) as text: queued as the string ``'3e-4'``, the trial failed when it trained."""
    if not isinstance(distribution, (optuna.distributions.FloatDistribution, optuna.distributions.IntDistribution)):
        return value  # a categorical parameter: the FixedTrial check names its choices
    kind = float if isinstance(distribution, optuna.distributions.FloatDistribution) else int
    number = value
    if isinstance(value, str):
        try:
            number = kind(value)
        except ValueError:
            number = None
    if isinstance(number, bool) or not isinstance(number, (int, float)) or not math.isfinite(number) \
            or number != kind(number):
        raise cli.UsageError(f"--enqueue {key}={value}: {key} must be {'a' if kind is float else 'a whole'} number")
    return kind(number)


def best_yaml(study: optuna.Study, env_id: str) -> str:
    """The best trial as a Zoo-style YAML entry for ``train.py --config``."""
    best = study.best_trial
    header = (f"# Best of {len(study.get_trials(states=(TrialState.COMPLETE,)))} trials of Optuna study "
              f"{study.study_name!r}: trial {best.number}, success rate {best.value:.1%}\n")
    return header + yaml.safe_dump({env_id: best.user_attrs["hyperparams"]}, sort_keys=False)


def export(storage: str, study_name: str, path: Path) -> int:
    """``--export``: the study's finished trials into ``path``; returns how many."""
    file = grid.sqlite_file(grid.storage_url(storage))
    if file is not None and (not file.is_file() or file.stat().st_size == 0):  # opening one would make its schema
        raise cli.UsageError(f"--export: no study {study_name!r}: {file} does not exist or is empty")
    try:
        study = optuna.load_study(study_name=study_name, storage=grid.open_storage(storage, 60, 300, create=False))
    except KeyError as err:
        raise cli.UsageError(f"--export: no study {study_name!r} in {storage}") from err
    trials = kept.kept_trials(study)
    kept.write(path, trials)
    return len(trials["trials"])


def open_study(storage: str, study_name: str,
               pruner: optuna.pruners.BasePruner | None = None) -> tuple[optuna.Study, RDBStorage]:
    """The tuning study ``study_name`` (made on first use) and its storage."""
    rdb = grid.open_storage(storage, heartbeat=60, grace=300)
    return optuna.create_study(storage=rdb, study_name=study_name, direction="maximize", load_if_exists=True,
                               pruner=pruner or optuna.pruners.MedianPruner(n_startup_trials=5, n_warmup_steps=1)), rdb


def tune(algo: str, env_id: str, storage: str, study_name: str, trials: int, settings: dict[str, Any],
         runs_dir: Path, pruner: optuna.pruners.BasePruner | None = None) -> optuna.Study:
    """Run trials until the study has ``trials`` finished ones (over all workers)."""
    study, rdb = open_study(storage, study_name, pruner)
    # Seeded by the trials already stored: a sampler seeded alike in every session drew the same
    # first configurations again after each resume (trials 3 and 4 repeated 0 and 1).
    study.sampler = optuna.samplers.TPESampler(seed=settings["seed"] + len(study.trials), n_startup_trials=5)
    retry = rdb.get_heartbeat_stale_trial_callback()
    study.optimize(objective(algo, env_id, settings, runs_dir, retry),
                   callbacks=[MaxTrialsCallback(trials, kept.FINISHED)],
                   catch=(ValueError,))
    return study


def main(argv: list[str] | None = None) -> int:
    warnings.filterwarnings("ignore", category=optuna.exceptions.ExperimentalWarning)
    parser = cli.Parser(prog="python -m agents.tuning", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter, epilog=f"env ids: {', '.join(TASKS)}")
    parser.add_argument("--algo", required=True, choices=sorted(ALGOS), help="the algorithm to tune")
    parser.add_argument("--env", default="LightSail-v0", choices=list(TASKS), metavar="ID", help="task id")
    parser.add_argument("--trials", type=cli.positive_int, default=40, help="finished trials, over all workers")
    parser.add_argument("--timesteps", type=cli.positive_int, help="budget of each trial (default: the shipped one)")
    parser.add_argument("--evaluations", type=cli.positive_int, default=10, help="evaluations (pruning points) per trial")
    parser.add_argument("--eval-episodes", type=cli.positive_int, default=50, help="episodes per evaluation")
    parser.add_argument("--seed", type=cli.non_negative_int, default=0, help="seed of the trials and of the sampler")
    parser.add_argument("--storage", default=grid.DEFAULT_STORAGE, help="SQLAlchemy URL (sqlite:///FILE, postgresql://…)")
    parser.add_argument("--residual", choices=list(RESIDUAL_BASES),
                        help="tune a policy that corrects this controller (agents/residual.py); the search adds "
                             "the correction's size")
    parser.add_argument("--study", help="study name (default: tune-<algo>-<env>, tune-<algo>-residual-<base>-<env>)")
    parser.add_argument("--runs-dir", type=Path, default=Path("runs/tuning"), help="where trials keep their files")
    files = parser.add_mutually_exclusive_group()
    files.add_argument("--export", type=Path, metavar="FILE", help="write the study's finished trials as JSON and stop")
    files.add_argument("--import", dest="import_file", type=Path, metavar="FILE",
                      help="add the finished trials of FILE (written by --export) the study lacks and stop")
    files.add_argument("--enqueue", nargs="+", metavar="KEY=VALUE",
                       help="queue one configuration (every parameter of the search space) as the study's "
                            "next trial and stop")
    try:
        args = parser.parse_args(argv)
        kind = f"{args.algo}-residual-{args.residual}" if args.residual else args.algo
        study_name = args.study or f"tune-{kind}-{args.env}"
        if args.export:
            cli.check_writable_dir(args.export.parent, "--export")
            if args.export.is_dir():
                raise cli.UsageError(f"--export {args.export} is a directory")
            print(f"{export(args.storage, study_name, args.export)} finished trials of {study_name} -> {args.export}")
            return 0
        if args.import_file:
            trials = kept.read(args.import_file, study_name, "--import")
            added = kept.add_trials(open_study(args.storage, study_name)[0], trials)
            print(f"{added} finished trials of {args.import_file} added to {study_name} ({args.storage})")
            return 0
        if args.enqueue:
            params = configuration(args.algo, args.residual, args.enqueue)  # checked before the storage opens
            open_study(args.storage, study_name)[0].enqueue_trial(params)
            print(f"queued in {study_name} ({args.storage}): {params}")
            return 0
        cli.check_writable_dir(args.runs_dir, "--runs-dir")
    except cli.UsageError as err:
        return cli.fail(err)
    timesteps = args.timesteps or int(load_hyperparams(args.algo, args.env)["n_timesteps"])
    settings = {"timesteps": timesteps, "eval_freq": max(timesteps // args.evaluations, 1),
                "eval_episodes": args.eval_episodes, "seed": args.seed, "residual": args.residual}
    optuna.logging.set_verbosity(optuna.logging.INFO)
    try:
        with training.stopping_on_signals():
            study = tune(args.algo, args.env, args.storage, study_name, args.trials, settings,
                         args.runs_dir / study_name)
    except cli.UsageError as err:  # a storage that cannot be opened
        return cli.fail(err)
    except KeyboardInterrupt as stop:
        print(f"{stop}: the trial is queued again; the same command resumes it from its checkpoint", flush=True)
        return 130
    out = args.runs_dir / study_name / "best.yml"
    cli.write_whole(out, best_yaml(study, args.env))
    print(f"best: trial {study.best_trial.number}, success {study.best_value:.1%} -> {out}\n"
          f"train it: python train.py --algo {args.algo} --env {args.env} --config {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
