"""Train a Stable-Baselines3 agent on a lightsail-gym task (RL Baselines3 Zoo conventions).

    python train.py --algo ppo                        # the defaults: a good PPO on LightSail-v0
    python train.py --algo sac --env LightSailDeepDish-v0 --timesteps 200000 --seed 1
    python train.py --resume runs/LightSail-v0-ppo-0  # continue an interrupted run

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (keyed by env id, or
``--config FILE``); flags override them. Each run gets a directory of its own: ``--out``,
or ``runs/<env>-<algo>-<seed>`` numbered ``_2``, ``_3``, … when that one holds an earlier
run (``runs/latest`` then points at the newest). A new run never writes into an old one;
``--resume DIR`` continues the run in ``DIR`` from its newest checkpoint. A run directory holds:

    run.json                          versions, seed, configuration, one entry per session
    best_model.zip (+ _vecnormalize.pkl)   best evaluation success rate (mean return breaks ties)
    best_model.json                   when and how well it was evaluated
    final_model.zip (+ _vecnormalize.pkl)  at the end of training
    checkpoints/rl_model_<N>_steps.zip (+ normaliser, replay buffer)   also written at the end,
                                      on Ctrl-C and on SIGTERM
    evaluations.npz, tb/              evaluation history, TensorBoard logs
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import shlex
import signal
import sys
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv, VecMonitor, VecNormalize

import sail_env  # noqa: F401  (registers the env ids)
from agents import cli
from agents.sb3 import (ALGOS, ModelLoadError, algo_kwargs, load_hyperparams, normalize_kwargs,
                        normalizer_path, one_thread_per_process, save_model, versions)
from agents.vec_env import BatchedVecEnv
from sail_env.tasks import TASKS

CHECKPOINT_PREFIX = "rl_model"
#: Evaluation episodes during training are seeded apart from the training envs and from
#: evaluate.py's default seed, so the best model is not selected on the reported episodes.
EVAL_SEED_OFFSET = 10_000
#: Evaluation episodes run this many at a time (the episodes are the same for any number).
EVAL_ENVS = 10
RUNS_ROOT = Path("runs")
DEFAULT_SAVE_FREQ = 50_000
PPO_DEFAULT_N_STEPS = inspect.signature(ALGOS["ppo"]).parameters["n_steps"].default
#: Called after each evaluation with (timesteps, success rate); may raise to stop training
#: (the hyperparameter search prunes this way).
EvaluationHook = Callable[[int, float], None]
CONFIG_KEYS = frozenset({"algo", "env", "seed", "vec_env", "eval_freq", "eval_episodes", "save_freq",
                         "hyperparams_file", "hyperparams"})
#: YAML keys that set up the run rather than the algorithm.
RUN_KEYS = frozenset({"n_envs", "n_timesteps", "normalize", "policy"})


def positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = cli.Parser(prog="train.py", description=__doc__.splitlines()[0], formatter_class=cli.HelpFormatter,
                        epilog=f"env ids: {', '.join(TASKS)}")
    parser.add_argument("--algo", choices=sorted(ALGOS), help="required unless --resume")
    parser.add_argument("--env", default="LightSail-v0", choices=list(TASKS), metavar="ID")
    parser.add_argument("-n", "--timesteps", type=positive_int, help="total training steps (overrides n_timesteps)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--n-envs", type=positive_int, help="parallel training envs (overrides n_envs)")
    parser.add_argument("--vec-env", choices=("batched", "dummy", "subproc"), default="batched",
                        help="batched: all envs in one NumPy batch (LightSailVectorEnv); dummy/subproc: SB3's "
                             "one-env-at-a-time wrappers")
    parser.add_argument("--out", type=Path, help="run directory (default: runs/<env>-<algo>-<seed>, numbered if taken)")
    parser.add_argument("--config", type=Path, help="Zoo-style hyperparameter YAML keyed by env id "
                                                    "(default: agents/hyperparams/<algo>.yml)")
    parser.add_argument("--resume", type=Path, metavar="DIR", help="continue the run in DIR from its newest checkpoint")
    parser.add_argument("--eval-freq", type=int, default=10_000, help="evaluate every N steps (<= 0: never)")
    parser.add_argument("--eval-episodes", type=positive_int, default=100, help="episodes per evaluation")
    parser.add_argument("--save-freq", type=int, default=DEFAULT_SAVE_FREQ, help="checkpoint every N steps (<= 0: only at the end)")
    parser.add_argument("--no-progress-bar", action="store_true",
                        help="no bar on a terminal (without one, as in a log file, the evaluations' lines show progress)")
    args = parser.parse_args(argv)
    if args.seed < 0:
        parser.error(f"argument --seed: must be >= 0, got {args.seed}")
    if args.resume is None and args.algo is None:
        parser.error("--algo is required (unless --resume)")
    return args


def run_config(args: argparse.Namespace) -> dict[str, Any]:
    """Algo, env, seed and hyperparameters: from the YAML and flags, or from the run being resumed."""
    if args.resume is not None:
        try:
            config = json.loads((args.resume / "run.json").read_text())["config"]
        except (OSError, ValueError, KeyError) as err:
            raise ModelLoadError(f"{args.resume / 'run.json'}: cannot read the run to resume ({type(err).__name__})") from err
        missing = sorted(CONFIG_KEYS - set(config))
        if missing:
            raise ModelLoadError(f"{args.resume / 'run.json'}: not a run configuration (lacks {', '.join(missing)})")
        if args.timesteps is not None:
            config["hyperparams"]["n_timesteps"] = args.timesteps
        return config
    hyperparams = load_hyperparams(args.algo, args.env, args.config)
    if args.timesteps is not None:
        hyperparams["n_timesteps"] = args.timesteps
    if args.n_envs is not None:
        hyperparams["n_envs"] = args.n_envs
    config = {"algo": args.algo, "env": args.env, "seed": args.seed, "vec_env": args.vec_env,
            "eval_freq": args.eval_freq, "eval_episodes": args.eval_episodes, "save_freq": args.save_freq,
            "hyperparams_file": str(args.config or f"agents/hyperparams/{args.algo}.yml"),
            "hyperparams": hyperparams}
    return config


def check_hyperparams(config: dict[str, Any]) -> None:
    """A YAML entry's budget and keywords, before anything is written (ValueError names the entry)."""
    algo, hp, where = config["algo"], config["hyperparams"], f"{config['hyperparams_file']} [{config['env']}]"
    for key, default in (("n_timesteps", None), ("n_envs", 1)):
        value = hp.get(key, default)
        if value is None:
            raise ValueError(f"{where}: {key} is missing")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 1 or value != int(value):
            raise ValueError(f"{where}: {key} must be a whole number >= 1, got {value!r}")
    accepted = set(inspect.signature(ALGOS[algo]).parameters) | RUN_KEYS | {"noise_type", "noise_std"}
    unknown = sorted(set(hp) - accepted)
    if unknown:
        raise ValueError(f"{where}: {algo} has no hyperparameter {', '.join(unknown)}")
    try:
        normalize_kwargs(hp.get("normalize", False))
        algo_kwargs({k: v for k, v in hp.items() if k not in RUN_KEYS}, 1)
    except ValueError as err:
        raise ValueError(f"{where}: {err}") from err


def whole_rollouts(algo: str, total: int, hp: dict[str, Any]) -> int:
    """PPO collects whole rollouts of ``n_steps × n_envs``: the budget it will really train."""
    if algo != "ppo":
        return total
    rollout = int(hp.get("n_steps", PPO_DEFAULT_N_STEPS)) * int(hp.get("n_envs", 1))
    return math.ceil(total / rollout) * rollout


def new_run_dir(env_id: str, algo: str, seed: int, root: Path = RUNS_ROOT) -> Path:
    """``root/<env>-<algo>-<seed>``, or the first of ``…_2``, ``…_3``, … that holds no run."""
    base = root / f"{env_id}-{algo}-{seed}"
    candidates = (base if k == 1 else base.with_name(f"{base.name}_{k}") for k in range(1, 10_000))
    return next(path for path in candidates if not (path / "run.json").exists())


def point_latest(run_dir: Path) -> None:
    """``runs/latest`` names the newest run, so commands can refer to it."""
    latest = run_dir.parent / "latest"
    if latest.is_symlink() or not latest.exists():
        latest.unlink(missing_ok=True)
        latest.symlink_to(run_dir.name, target_is_directory=True)


def make_env(env_id: str, n_envs: int, seed: int, vec_env: str, normalize: dict[str, Any] | None,
             gamma: float, training: bool) -> VecEnv:
    """``n_envs`` seeded envs with episode statistics (success logged), maybe normalised.

    ``batched`` steps them as one ``LightSailVectorEnv`` behind :class:`BatchedVecEnv`;
    ``dummy`` and ``subproc`` are SB3's wrappers of single envs, with the same episodes.
    """
    if vec_env == "batched":
        venv = VecMonitor(BatchedVecEnv(gym.make_vec(env_id, num_envs=n_envs, vectorization_mode="vector_entry_point")),
                          info_keywords=("is_success",))
        venv.seed(seed)
    else:
        venv = make_vec_env(env_id, n_envs=n_envs, seed=seed,
                            vec_env_cls=SubprocVecEnv if vec_env == "subproc" and n_envs > 1 else DummyVecEnv,
                            monitor_kwargs={"info_keywords": ("is_success",)})
    if normalize is None:
        return venv
    if not training:  # statistics are synced from the training env before each evaluation
        return VecNormalize(venv, training=False, norm_reward=False, gamma=gamma)
    return VecNormalize(venv, gamma=gamma, **normalize)


def checkpoint_steps(path: Path) -> int:
    """The step count in a checkpoint's name, ``rl_model_<N>_steps.zip``."""
    return int(path.stem.split("_")[-2])


def latest_checkpoint(run_dir: Path, normalized: bool = False) -> Path:
    """The checkpoint with the most steps in ``run_dir/checkpoints`` that was written completely:
    a whole zip and, for a ``normalized`` run, its statistics (a process killed while saving
    leaves the newest one incomplete; the one before it is then the latest)."""
    found = sorted((run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"), key=checkpoint_steps)
    complete = [path for path in found if zipfile.is_zipfile(path) and (not normalized or normalizer_path(path).is_file())]
    if not complete:
        raise ModelLoadError(f"{run_dir / 'checkpoints'}: no complete checkpoint to resume from")
    return complete[-1]


def save_checkpoint(model: BaseAlgorithm, run_dir: Path) -> Path:
    """Model, normaliser and replay buffer under the names CheckpointCallback uses."""
    path = run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_{model.num_timesteps}_steps.zip"
    save_model(model, path)
    if getattr(model, "replay_buffer", None) is not None:
        model.save_replay_buffer(path.with_name(f"{CHECKPOINT_PREFIX}_replay_buffer_{model.num_timesteps}_steps.pkl"))
    return path


class KeepBestBySuccess(BaseCallback):
    """After each EvalCallback evaluation: keep the model with the best (success rate, mean return).

    Also re-seeds the eval env, so every evaluation plays the same episodes (paired), and
    hands the success rate to ``on_evaluation`` if given.
    """

    def __init__(self, run_dir: Path, eval_seed: int, on_evaluation: EvaluationHook | None = None) -> None:
        super().__init__()
        self.run_dir, self.eval_seed, self.on_evaluation = run_dir, eval_seed, on_evaluation
        record = run_dir / "best_model.json"
        self.best = json.loads(record.read_text()) if record.is_file() else None

    def _on_step(self) -> bool:
        evaluation = self.parent
        successes = evaluation.evaluations_successes[-1]
        score = {"timesteps": self.num_timesteps, "success_rate": sum(successes) / len(successes),
                 "mean_return": evaluation.last_mean_reward, "episodes": len(successes)}
        key = (score["success_rate"], score["mean_return"])
        new_best = self.best is None or key > (self.best["success_rate"], self.best["mean_return"])
        print(f"eval at {self.num_timesteps} steps: success {score['success_rate']:.1%}, "
              f"mean return {score['mean_return']:.2f}{' (new best)' if new_best else ''}", flush=True)
        if new_best:
            self.best = score
            save_model(self.model, self.run_dir / "best_model.zip")
            (self.run_dir / "best_model.json").write_text(json.dumps(score, indent=2))
        evaluation.eval_env.seed(self.eval_seed)
        if self.on_evaluation is not None:
            self.on_evaluation(self.num_timesteps, score["success_rate"])
        return True


def read_run(run_dir: Path) -> dict[str, Any]:
    """A run's ``run.json``."""
    return json.loads((run_dir / "run.json").read_text())


def read_best(run_dir: Path) -> dict[str, Any]:
    """When and how well a run's best model was evaluated (``best_model.json``)."""
    return json.loads((run_dir / "best_model.json").read_text())


def write_run_json(run_dir: Path, config: dict[str, Any], sessions: list[dict[str, Any]]) -> None:
    """Configuration, versions, and one entry per session (command, status, steps, wall time)."""
    record = {"command": sessions[0]["command"], "config": config, "versions": versions(), "sessions": sessions}
    (run_dir / "run.json").write_text(json.dumps(record, indent=2))


def build_model(config: dict[str, Any], train_env: VecEnv, run_dir: Path, resume_from: Path | None) -> BaseAlgorithm:
    """A new model from the hyperparameters, or the checkpoint ``resume_from`` with its buffer."""
    algo, hp = config["algo"], dict(config["hyperparams"])
    policy = hp.get("policy", "MlpPolicy")
    hp = {k: v for k, v in hp.items() if k not in RUN_KEYS}
    if resume_from is None:
        where = f"{config['hyperparams_file']} [{config['env']}]"
        try:
            kwargs = algo_kwargs(hp, train_env.action_space.shape[0])
            return ALGOS[algo](policy, train_env, seed=config["seed"], device="cpu", verbose=0,
                               tensorboard_log=str(run_dir / "tb"), **kwargs)
        except (TypeError, ValueError, KeyError) as err:  # an unknown or malformed hyperparameter
            raise ValueError(f"{where}: {algo} does not accept these hyperparameters ({err})") from err
    model = ALGOS[algo].load(resume_from, env=train_env, device="cpu", tensorboard_log=str(run_dir / "tb"))
    buffer = resume_from.with_name(f"{CHECKPOINT_PREFIX}_replay_buffer_{checkpoint_steps(resume_from)}_steps.pkl")
    if buffer.is_file():
        model.load_replay_buffer(buffer)
    return model


def train(config: dict[str, Any], run_dir: Path, command: str, resume: bool = False, progress_bar: bool = False,
          on_evaluation: EvaluationHook | None = None) -> dict[str, Any]:
    """Train (or, with ``resume``, continue) the run ``config`` in ``run_dir``; the session record.

    Ctrl-C or SIGTERM (see :func:`stop_on_signals`) save a checkpoint and end the session as
    ``interrupted``; an exception from ``on_evaluation`` propagates after the run is recorded.
    """
    algo, env_id, seed = config["algo"], config["env"], config["seed"]
    hp = config["hyperparams"]
    n_envs, normalize, gamma = int(hp.get("n_envs", 1)), normalize_kwargs(hp.get("normalize", False)), hp.get("gamma", 0.99)
    resume_from = latest_checkpoint(run_dir, normalize is not None) if resume else None
    offset = checkpoint_steps(resume_from) if resume_from else 0
    total = whole_rollouts(algo, int(hp["n_timesteps"]), hp)
    if resume_from is not None and offset >= total:
        raise ValueError(f"{run_dir} has trained its {offset} steps: give --timesteps above {offset} to extend it")
    run_dir.mkdir(parents=True, exist_ok=True)
    one_thread_per_process()
    set_random_seed(seed)

    # A resumed run draws new episodes: reseed by the step count it continues from.
    train_env = make_env(env_id, n_envs, seed + offset, config["vec_env"], normalize, gamma, training=True)
    eval_env = make_env(env_id, max(1, min(EVAL_ENVS, config["eval_episodes"])), seed + EVAL_SEED_OFFSET,
                        config["vec_env"], normalize, gamma, training=False)
    if resume_from is not None and normalize is not None:
        train_env = VecNormalize.load(str(normalizer_path(resume_from)), train_env.venv)
    try:
        model = build_model(config, train_env, run_dir, resume_from)
        callbacks: list[BaseCallback] = []
        if config["save_freq"] > 0:
            callbacks.append(UninterruptedCheckpoints(max(config["save_freq"] // n_envs, 1), str(run_dir / "checkpoints"),
                                                CHECKPOINT_PREFIX, save_replay_buffer=True, save_vecnormalize=True))
        if config["eval_freq"] > 0:
            eval_env.seed(seed + EVAL_SEED_OFFSET)
            callbacks.append(EvalCallback(
                eval_env, n_eval_episodes=config["eval_episodes"], eval_freq=max(config["eval_freq"] // n_envs, 1),
                log_path=str(run_dir), best_model_save_path=None, deterministic=True, verbose=0,
                callback_after_eval=KeepBestBySuccess(run_dir, seed + EVAL_SEED_OFFSET, on_evaluation)))

        sessions = read_run(run_dir)["sessions"] if resume_from else []
        session = {"command": command, "status": "running", "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                   "start_timesteps": model.num_timesteps}
        sessions.append(session)
        write_run_json(run_dir, config, sessions)
        start, status = time.perf_counter(), "finished"
        try:
            model.learn(total - model.num_timesteps, callback=callbacks, tb_log_name="tb",
                        reset_num_timesteps=resume_from is None, progress_bar=progress_bar)
        except KeyboardInterrupt:
            status = "interrupted"
        except BaseException:
            status = "stopped"
            raise
        finally:
            save_checkpoint(model, run_dir)
            if status == "finished":
                save_model(model, run_dir / "final_model.zip")
            session.update(status=status, timesteps=model.num_timesteps,
                           wall_time_s=round(time.perf_counter() - start, 1))
            write_run_json(run_dir, config, sessions)
    finally:
        train_env.close()
        eval_env.close()
    return session


def header(config: dict[str, Any], run_dir: Path, resume: bool) -> str:
    """What is about to run, before it runs."""
    hp = config["hyperparams"]
    total, asked = whole_rollouts(config["algo"], int(hp["n_timesteps"]), hp), int(hp["n_timesteps"])
    budget = f"{asked:,} steps" + (f" (whole rollouts: {total:,})" if total != asked else "")
    return (f"{'resuming' if resume else 'training'} {config['algo']} on {config['env']}, seed {config['seed']}, "
            f"{budget}, {hp.get('n_envs', 1)} envs ({config['vec_env']}), hyperparameters "
            f"{config['hyperparams_file']} -> {run_dir}")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        args = parse_args(argv)
        config = run_config(args)
        check_hyperparams(config)
        if args.resume is not None:
            run_dir = args.resume
        elif args.out is not None:
            run_dir = args.out
            if (run_dir / "run.json").exists():
                raise ValueError(f"{run_dir} holds a run already: --resume {run_dir} continues it, "
                                 "or choose another --out")
        else:
            run_dir = new_run_dir(config["env"], config["algo"], config["seed"])
        print(header(config, run_dir, args.resume is not None), flush=True)
        if args.resume is None and args.out is None:
            run_dir.mkdir(parents=True, exist_ok=True)
            point_latest(run_dir)
        session = train(config, run_dir, shlex.join(["python", "train.py", *argv]), resume=args.resume is not None,
                        progress_bar=not args.no_progress_bar and sys.stderr.isatty())
    except (ModelLoadError, ValueError) as err:
        return cli.fail(err)
    status = session["status"]
    print(f"{status}: {session['timesteps']:,} steps in {session['wall_time_s']:.0f} s -> {run_dir}")
    if status == "interrupted":
        print(f"continue with: python train.py --resume {run_dir}")
        return 130
    return 0


#: Set while a checkpoint is written; a signal then only records itself (see :func:`stop_on_signals`).
_saving = {"active": False, "pending": None}


class UninterruptedCheckpoints(CheckpointCallback):
    """SB3's checkpoints, each written whole: a Ctrl-C or SIGTERM that arrives during the write is
    raised after it (raised inside, it broke torch's zip writer and the run ended with an error)."""

    def _on_step(self) -> bool:
        _saving["active"] = True
        try:
            return super()._on_step()
        finally:
            _saving["active"] = False
            pending, _saving["pending"] = _saving["pending"], None
            if pending is not None:
                raise KeyboardInterrupt(pending)


def stop_on_signals() -> None:
    """SIGINT and SIGTERM (a scheduler's pre-emption) both save a checkpoint and stop.

    A shell without job control starts background jobs with SIGINT ignored, and Python
    then never raises KeyboardInterrupt: restore it explicitly.
    """
    def interrupt(signum: int, frame: object) -> None:
        if _saving["active"]:
            _saving["pending"] = signal.Signals(signum).name
            return
        raise KeyboardInterrupt(signal.Signals(signum).name)

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, interrupt)
