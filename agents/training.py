"""Train a Stable-Baselines3 agent on a lightsail-gym task (RL Baselines3 Zoo conventions).

    python train.py --algo ppo                        # the defaults: a good PPO on LightSail-v0
    python train.py --algo sac --env LightSailDeepDish-v0 --timesteps 200000 --seed 1
    python train.py --resume runs/LightSail-v0-ppo-0  # continue an interrupted run

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (keyed by env id, or
``--config FILE``); flags override them. Each run gets a directory of its own: ``--out``,
or ``runs/<env>-<algo>-<seed>`` numbered ``_2``, ``_3``, … when that folder exists already
(made atomically, so two runs started at once get two folders; ``runs/latest`` then points
at the newest). A new run never writes into an old one;
``--resume DIR`` continues the run in ``DIR`` from its newest checkpoint (PPO: from the end of the
last rollout that checkpoint learnt from) to the budget it announces, with the run's own settings:
``--timesteps`` extends it, ``--eval-freq``, ``--save-freq`` and ``--vec-env`` apply (said on the first
line), any other run flag that differs from the run's is refused. Evaluations fall every
``--eval-freq`` steps of the run (a resumed run evaluates where an uninterrupted one does) and at its
end. A run directory holds:

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
import contextlib
import inspect
import json
import math
import os
import shlex
import signal
import sys
import time
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.save_util import load_from_zip_file
from stable_baselines3.common.type_aliases import TrainFrequencyUnit
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import (DummyVecEnv, SubprocVecEnv, VecEnv, VecFrameStack, VecMonitor,
                                              VecNormalize)

import sail_env  # noqa: F401  (registers the env ids)
from agents import cli
from agents.cli import positive_int
from agents.sb3 import (ALGOS, ON_POLICY, SCHEDULES, ModelLoadError, algo_kwargs, frame_stack_of, load_hyperparams,
                        load_normalizer, normalize_kwargs, normalizer_path, one_thread_per_process, policy_of,
                        save_model, schedule, unstacked_shape, versions)
from agents.residual import ResidualVecEnv, residual_of
from agents.shaping import PotentialShapingVecEnv, shaping_of
from agents.vec_env import BatchedVecEnv
from sail_env.tasks import TASKS

CHECKPOINT_PREFIX = "rl_model"
#: Evaluation episodes during training are seeded apart from the training envs and from
#: evaluate.py's default seed, so the best model is not selected on the reported episodes.
EVAL_SEED_OFFSET = 10_000
RUNS_ROOT = Path("runs")
DEFAULT_SAVE_FREQ = 50_000
#: Called after each evaluation with (timesteps, success rate); may raise to stop training
#: (the hyperparameter search prunes this way).
EvaluationHook = Callable[[int, float], None]
CONFIG_KEYS = frozenset({"algo", "env", "seed", "vec_env", "eval_freq", "eval_episodes", "save_freq",
                         "hyperparams_file", "hyperparams"})
#: YAML keys that set up the run rather than the algorithm. ``frame_stack: k``: the policy sees the
#: last k (normalised) observations side by side (VecFrameStack, as in RL Baselines3 Zoo). ``residual``
#: and ``residual_scale``: the policy corrects a classical controller (agents/residual.py).
#: ``reward_shaping``: the training env's reward, potential-shaped (agents/shaping.py).
RUN_KEYS = frozenset({"n_envs", "n_timesteps", "normalize", "policy", "frame_stack", "residual", "residual_scale",
                      "reward_shaping"})
#: The least value of each whole-number hyperparameter. Below it SB3 fails late and far from the
#: YAML (n_steps 0 divides by zero, batch_size -3 trips an assert, n_epochs 0 an unbound local
#: after the first rollout). batch_size 2: PPO normalises advantages over a batch (a batch of one
#: divides by zero); one floor for every algorithm keeps one table. -1 means "as many as steps".
WHOLE_NUMBER_MINIMUMS = {"n_timesteps": 1, "n_envs": 1, "frame_stack": 1, "n_steps": 1, "batch_size": 2, "n_epochs": 1,
                         "buffer_size": 1, "learning_starts": 0, "train_freq": 1, "gradient_steps": -1,
                         "target_update_interval": 1, "policy_delay": 1, "sde_sample_freq": -1}


#: The flags that set up a run, as argparse names them: ``--resume`` takes them from the stored run.
#: A given one that contradicts it is refused, except those in :data:`RESUME_APPLIES`.
RUN_FLAGS = ("algo", "env", "seed", "n_envs", "vec_env", "out", "config", "eval_freq", "eval_episodes", "save_freq")
#: Flags a resumed run applies (and says so): they change how it continues, not what it trains. The
#: batched and one-env-at-a-time wrappers play the same episodes; the evaluation schedule counts
#: total steps whatever its frequency.
RESUME_APPLIES = ("vec_env", "eval_freq", "save_freq")


def build_parser() -> cli.Parser:
    """train.py's command line."""
    parser = cli.Parser(prog="train.py", description=cli.describe(__doc__), formatter_class=cli.HelpFormatter,
                        epilog=f"env ids: {', '.join(TASKS)}")
    parser.add_argument("--algo", choices=sorted(ALGOS), help="required unless --resume")
    parser.add_argument("--env", default="LightSail-v0", choices=list(TASKS), metavar="ID", help="task id")
    parser.add_argument("-n", "--timesteps", type=positive_int,
                        help="total training steps (default: the hyperparameter entry's n_timesteps)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--n-envs", type=positive_int, help="parallel training envs (overrides n_envs)")
    parser.add_argument("--vec-env", choices=("batched", "dummy", "subproc"), default="batched",
                        help="batched: all envs in one NumPy batch (LightSailVectorEnv); dummy/subproc: SB3's "
                             "one-env-at-a-time wrappers")
    parser.add_argument("--out", type=Path, help="run directory (default: runs/<env>-<algo>-<seed>, numbered if taken)")
    parser.add_argument("--config", type=Path, help="Zoo-style hyperparameter YAML keyed by env id "
                                                    "(default: agents/hyperparams/<algo>.yml)")
    parser.add_argument("--resume", type=Path, metavar="DIR",
                        help="continue the run in DIR from its newest checkpoint, with its settings (see above)")
    parser.add_argument("--eval-freq", type=int, default=10_000, help="evaluate every N steps of the run and at its end "
                                                                      "(<= 0: never)")
    parser.add_argument("--eval-episodes", type=positive_int, default=100, help="episodes per evaluation")
    parser.add_argument("--save-freq", type=int, default=DEFAULT_SAVE_FREQ, help="checkpoint every N steps (<= 0: only at the end)")
    parser.add_argument("--no-progress-bar", action="store_true",
                        help="no bar on a terminal (without one, as in a log file, the evaluations' lines show progress)")
    return parser

#: The ranges of the real-valued hyperparameters SB3 takes without checking them: ``(low, high,
#: low included)`` (a finite high end included, infinity not). Out of range, SB3 trains on regardless (``gamma: 1.5``
#: overflows the returns' discounting and exits 0). A schedule (``lin_<number>``) is checked by its start.
REAL_RANGES = {"gamma": (0.0, 1.0, True), "gae_lambda": (0.0, 1.0, True), "tau": (0.0, 1.0, False),
               "learning_rate": (0.0, math.inf, False), "clip_range": (0.0, math.inf, False),
               "ent_coef": (0.0, math.inf, True), "vf_coef": (0.0, math.inf, True),
               "max_grad_norm": (0.0, math.inf, False), "target_kl": (0.0, math.inf, False),
               "noise_std": (0.0, math.inf, True), "target_policy_noise": (0.0, math.inf, True),
               "target_noise_clip": (0.0, math.inf, True)}
#: Those SB3 also accepts as None (off) or as text (SAC's ``ent_coef: auto``, ``auto_0.1``: SB3's own check).
REAL_OPTIONAL = {"target_kl": (type(None),), "ent_coef": (str,)}


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = build_parser()
    args = parser.parse_args(argv)
    # Which run flags the command line gave (a default cannot contradict the run being resumed).
    unset, given = object(), build_parser()
    given.set_defaults(**dict.fromkeys(RUN_FLAGS, unset))
    args.given = {flag for flag, value in vars(given.parse_args(argv)).items()
                  if flag in RUN_FLAGS and value is not unset}
    if args.seed < 0:
        parser.error(f"argument --seed: must be >= 0, got {args.seed}")
    if args.resume is None and args.algo is None:
        parser.error("--algo is required (unless --resume)")
    return args


def run_config(args: argparse.Namespace) -> tuple[dict[str, Any], list[str]]:
    """Algo, env, seed and hyperparameters: from the YAML and flags, or from the run being resumed;
    and, for a resumed run, one line for each flag it applies (:func:`resumed_config`)."""
    if args.resume is not None:
        return resumed_config(args)
    hyperparams = load_hyperparams(args.algo, args.env, args.config)
    if args.timesteps is not None:
        hyperparams["n_timesteps"] = args.timesteps
    if args.n_envs is not None:
        hyperparams["n_envs"] = args.n_envs
    config = {"algo": args.algo, "env": args.env, "seed": args.seed, "vec_env": args.vec_env,
              "eval_freq": args.eval_freq, "eval_episodes": args.eval_episodes, "save_freq": args.save_freq,
              "hyperparams_file": str(args.config or f"agents/hyperparams/{args.algo}.yml"),
              "hyperparams": hyperparams}
    return config, []


def resumed_config(args: argparse.Namespace) -> tuple[dict[str, Any], list[str]]:
    """The stored configuration of the run in ``args.resume``, with ``--timesteps`` and the flags of
    :data:`RESUME_APPLIES` that the command line gave applied (one line each says so). Any other run
    flag given with a value other than the run's is refused (:class:`cli.UsageError`): it used to be
    ignored without a word (``--algo sac`` resumed a PPO run as PPO)."""
    try:
        config = json.loads((args.resume / "run.json").read_text())["config"]
    except (OSError, ValueError, KeyError) as err:
        raise ModelLoadError(f"{args.resume / 'run.json'}: cannot read the run to resume ({type(err).__name__})") from err
    missing = sorted(CONFIG_KEYS - set(config))
    if missing:
        raise ModelLoadError(f"{args.resume / 'run.json'}: not a run configuration (lacks {', '.join(missing)})")
    stored = {**{key: config[key] for key in CONFIG_KEYS & set(RUN_FLAGS)},
              "n_envs": config["hyperparams"].get("n_envs", 1), "config": config["hyperparams_file"],
              "out": str(args.resume)}
    notes: list[str] = []
    for flag in RUN_FLAGS:
        value = getattr(args, flag)
        if flag not in args.given or str(value) == str(stored[flag]):
            continue
        option = f"--{flag.replace('_', '-')} {value}"
        if flag not in RESUME_APPLIES:
            raise cli.UsageError(f"{option} contradicts the run in {args.resume} ({stored[flag]}): a resumed run keeps "
                                 "it (leave the flag out, or start a new run)")
        config[flag] = value
        notes.append(f"resuming with {option} (the run had {stored[flag]})")
    if args.timesteps is not None:
        config["hyperparams"]["n_timesteps"] = args.timesteps
    return config, notes


def check_hyperparams(config: dict[str, Any]) -> None:
    """A YAML entry's budget and keywords, before anything is written (ValueError names the entry)."""
    algo, hp, where = config["algo"], config["hyperparams"], f"{config['hyperparams_file']} [{config['env']}]"
    if "n_timesteps" not in hp:
        raise ValueError(f"{where}: n_timesteps is missing")
    for key, (low, high, low_included) in REAL_RANGES.items():
        value = hp.get(key)
        if key not in hp or isinstance(value, REAL_OPTIONAL.get(key, ())):
            continue
        try:
            number = schedule(key, value) if key in SCHEDULES else value
        except ValueError as err:
            raise ValueError(f"{where}: {err}") from err
        number = getattr(number, "start", number)  # a linear schedule's start
        inside = isinstance(number, (int, float)) and not isinstance(number, bool) and math.isfinite(number) and (
            low < number <= high or (low_included and number == low))
        if not inside:
            interval = f"{'[' if low_included else '('}{low:g}, {high:g}{']' if math.isfinite(high) else ')'}"
            raise ValueError(f"{where}: {key} must be a number in {interval}, got {value!r}")
    for key, least in WHOLE_NUMBER_MINIMUMS.items():
        value = hp.get(key)
        if value is None or (key == "train_freq" and isinstance(value, (list, tuple))):  # (n, "episode"): SB3's check
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value < least or value != int(value):
            raise ValueError(f"{where}: {key} must be a whole number >= {least}, got {value!r}")
    if algo in ON_POLICY and rollout_steps(algo, hp) < 2:
        raise ValueError(f"{where}: n_steps × n_envs (PPO's rollout) must be >= 2, "
                         f"got {hp.get('n_steps', default_n_steps(algo))} × {hp.get('n_envs', 1)}")
    # The observations are a flat vector: the CNN and dict policies cannot take them.
    if hp.get("policy", policy_of(algo)) != policy_of(algo):
        raise ValueError(f"{where}: policy must be {policy_of(algo)} (the observations are a flat vector), "
                         f"got {hp['policy']!r}")
    accepted = set(inspect.signature(ALGOS[algo]).parameters) | RUN_KEYS | {"noise_type", "noise_std"}
    unknown = sorted(set(hp) - accepted)
    if unknown:
        raise ValueError(f"{where}: {algo} has no hyperparameter {', '.join(unknown)}")
    try:
        normalized = normalize_kwargs(hp.get("normalize", False)) is not None
        residual_of(hp)
        shaping_of(hp)
        algo_kwargs({k: v for k, v in hp.items() if k not in RUN_KEYS}, 1)
    except ValueError as err:
        raise ValueError(f"{where}: {err}") from err
    # SB3's off-policy algorithms store VecNormalize's original observations in their replay buffer and
    # normalise them when sampling: below VecFrameStack those are single observations, not the stack
    # the policy sees (the first stored transition fails on the shapes).
    if algo not in ON_POLICY and normalized and frame_stack_of(hp) > 1:
        raise ValueError(f"{where}: frame_stack > 1 with normalize needs an on-policy algorithm "
                         f"({', '.join(sorted(ON_POLICY))}); {algo}'s replay buffer would store unstacked "
                         f"observations: set frame_stack: 1 or normalize: false")


def whole_rollouts(algo: str, total: int, hp: dict[str, Any]) -> int:
    """PPO collects whole rollouts of ``n_steps × n_envs``: the budget it will really train."""
    if algo not in ON_POLICY:
        return total
    rollout = rollout_steps(algo, hp)
    return math.ceil(total / rollout) * rollout


def default_n_steps(algo: str) -> int:
    """An on-policy algorithm's own ``n_steps`` (PPO 2048, RecurrentPPO 128)."""
    return inspect.signature(ALGOS[algo]).parameters["n_steps"].default


def rollout_steps(algo: str, hp: dict[str, Any]) -> int:
    """Env steps in one rollout of an on-policy algorithm: ``n_steps × n_envs``."""
    return int(hp.get("n_steps", default_n_steps(algo))) * int(hp.get("n_envs", 1))


def fresh_dir(base: Path) -> Path:
    """``base``, or the first of ``base_2``, ``base_3``, … that does not exist, now created (empty).

    ``os.mkdir`` fails on a folder that exists, so of two processes asking at once each gets
    its own: checking first and creating after, both took the same free name.
    """
    base.parent.mkdir(parents=True, exist_ok=True)
    for k in range(1, 10_000):
        path = base if k == 1 else base.with_name(f"{base.name}_{k}")
        try:
            os.mkdir(path)
        except FileExistsError:
            continue
        return path
    raise FileExistsError(f"{base}: no free name up to _9999")


def new_run_dir(env_id: str, algo: str, seed: int, root: Path = RUNS_ROOT) -> Path:
    """A new, empty ``root/<env>-<algo>-<seed>`` (numbered ``_2``, ``_3``, … if taken)."""
    return fresh_dir(root / f"{env_id}-{algo}-{seed}")


def point_latest(run_dir: Path) -> None:
    """``runs/latest`` names the newest run, so commands can refer to it. Replaced atomically
    (a new link renamed over it): a run started at the same time never finds it missing."""
    latest = run_dir.parent / "latest"
    if latest.exists() and not latest.is_symlink():
        return  # a folder of the user's own called latest: not ours to replace
    link = run_dir.parent / f".latest-{os.getpid()}"
    link.unlink(missing_ok=True)
    link.symlink_to(run_dir.name, target_is_directory=True)
    os.replace(link, latest)


def make_env(env_id: str, n_envs: int, seed: int, vec_env: str, normalize: dict[str, Any] | None,
             gamma: float, training: bool, frame_stack: int = 1, statistics: Path | None = None,
             residual: tuple[str, float] | None = None, shaping: str | None = None) -> VecEnv:
    """``n_envs`` seeded envs with episode statistics (success logged), maybe a residual policy's
    (``(base, scale)``: :class:`~agents.residual.ResidualVecEnv`), maybe with a shaped reward
    (``"potential"``: :class:`~agents.shaping.PotentialShapingVecEnv`), maybe normalised (by the
    VecNormalize ``statistics`` a checkpoint saved, when resuming), then with the last
    ``frame_stack`` normalised observations stacked (VecFrameStack; 1: none).

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
    if residual is not None:
        venv = ResidualVecEnv(venv, *residual)
    if shaping is not None:
        venv = PotentialShapingVecEnv(venv, gamma)
    if normalize is not None and statistics is not None:
        venv = VecNormalize.load(str(statistics), venv)
    elif normalize is not None and not training:  # statistics are synced from the training env before each evaluation
        venv = VecNormalize(venv, training=False, norm_reward=False, gamma=gamma)
    elif normalize is not None:
        venv = VecNormalize(venv, gamma=gamma, **normalize)
    return VecFrameStack(venv, frame_stack) if frame_stack > 1 else venv


def checkpoint_steps(path: Path) -> int:
    """The step count in a checkpoint's name, ``rl_model_<N>_steps.zip``."""
    return int(path.stem.split("_")[-2])


def complete_checkpoints(run_dir: Path, normalized: bool = False) -> list[Path]:
    """The checkpoints in ``run_dir/checkpoints`` that were written completely, oldest first: a
    whole zip and, for a ``normalized`` run, its statistics (a process killed while saving
    leaves the newest one incomplete)."""
    found = sorted((run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"), key=checkpoint_steps)
    return [path for path in found if zipfile.is_zipfile(path) and (not normalized or normalizer_path(path).is_file())]


def latest_checkpoint(run_dir: Path, normalized: bool = False) -> Path:
    """The complete checkpoint with the most steps (:func:`complete_checkpoints`)."""
    complete = complete_checkpoints(run_dir, normalized)
    if not complete:
        raise ModelLoadError(f"{run_dir / 'checkpoints'}: no complete checkpoint to resume from")
    return complete[-1]


def checkpoint_problem(path: Path, normalized: bool, frame_stack: int = 1) -> str | None:
    """Why a complete checkpoint cannot be loaded (a whole zip around a damaged ``policy.pth``,
    statistics cut short), or None if it loads."""
    try:
        data, _, _ = load_from_zip_file(path, device="cpu", print_system_info=False)
        if normalized:
            load_normalizer(normalizer_path(path), unstacked_shape(data["observation_space"].shape, frame_stack))
    except ModelLoadError as err:
        return str(err)
    except Exception as err:  # noqa: BLE001  (torch and pickle raise many types for damaged bytes)
        return f"{path}: {type(err).__name__}"
    return None


def resumable_checkpoint(run_dir: Path, hyperparams: dict[str, Any]) -> Path:
    """The newest complete checkpoint of a run with these hyperparameters that loads. Falling back
    past damaged ones is said on stderr in one line: the run then repeats the steps since the one
    it resumes from."""
    normalized = normalize_kwargs(hyperparams.get("normalize", False)) is not None
    damaged: list[str] = []
    for path in reversed(complete_checkpoints(run_dir, normalized)):
        problem = checkpoint_problem(path, normalized, frame_stack_of(hyperparams))
        if problem is None:
            if damaged:
                print(f"warning: resuming from {path.name}: the newer checkpoint{'s' * (len(damaged) > 1)} "
                      f"cannot be loaded ({'; '.join(damaged)})", file=sys.stderr, flush=True)
            return path
        damaged.append(problem)
    if damaged:
        raise ModelLoadError(f"{run_dir / 'checkpoints'}: no checkpoint loads ({damaged[0]})")
    raise ModelLoadError(f"{run_dir / 'checkpoints'}: no complete checkpoint to resume from")


def resume_point(run_dir: Path, config: dict[str, Any], checkpoint: Path) -> int:
    """The step count a run resumed from ``checkpoint`` continues from: its steps, or for PPO the end of
    the last rollout the checkpoint's weights have learned from.

    PPO learns at the end of each whole rollout of ``n_steps × n_envs``. A checkpoint written inside
    one (Ctrl-C, SIGTERM, a kill after a ``save_freq`` checkpoint that is not a whole number of
    rollouts), or at its last step (before its update), holds the weights of the rollouts before:
    continuing its step count, the run trained more than the budget it announced (rollouts from an
    odd start overshoot it), learnt nothing from the interrupted rollout, and evaluated at other
    points than an uninterrupted run. Only a session's final checkpoint has learnt its last rollout.
    """
    steps = checkpoint_steps(checkpoint)
    if config["algo"] not in ON_POLICY:
        return steps
    sessions = read_run(run_dir).get("sessions", [])
    if any(s.get("status") == "finished" and s.get("timesteps") == steps for s in sessions):
        return steps
    rollout = rollout_steps(config["algo"], config["hyperparams"])
    return max(steps - 1, 0) // rollout * rollout


def save_checkpoint(model: BaseAlgorithm, run_dir: Path) -> Path:
    """Model, normaliser and replay buffer under the names CheckpointCallback uses."""
    path = run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_{model.num_timesteps}_steps.zip"
    save_model(model, path)
    if getattr(model, "replay_buffer", None) is not None:
        model.save_replay_buffer(path.with_name(f"{CHECKPOINT_PREFIX}_replay_buffer_{model.num_timesteps}_steps.pkl"))
    return path


class EvalOnTotalSteps(EvalCallback):
    """SB3's EvalCallback on a schedule of the run's env steps (every ``every`` of them), not of this
    session's calls: a resumed run evaluates at the points an uninterrupted one does (counted from the
    resume, a run resumed at 1,000 of 2,048 steps with ``--eval-freq 2048`` never evaluated and left
    no best model). :meth:`evaluate_final` evaluates the model a session ends with, if no evaluation
    did at its step count."""

    def __init__(self, eval_env: VecEnv, every: int, **kwargs: Any) -> None:
        super().__init__(eval_env, eval_freq=1, **kwargs)  # every call passes SB3's own schedule
        self.every = every

    def _on_step(self) -> bool:
        return self.num_timesteps % self.every != 0 or super()._on_step()

    def evaluate_final(self) -> None:
        """Evaluate the trained model unless an evaluation has at its step count (a short budget,
        ``--eval-freq`` above it or not dividing it): every run that evaluates ends with a best model."""
        if self.model.num_timesteps not in self.evaluations_timesteps[-1:]:
            self.num_timesteps = self.model.num_timesteps
            super()._on_step()


class StopAtBudget(BaseCallback):
    """Ends an off-policy session at ``total`` steps. SB3 collects ``train_freq`` steps between updates
    and stops only at the end of such a chunk: from a resume inside one, the run overshot its
    budget. A chunk that ends at the budget ends it (its update is made); one cut at the budget is
    not learnt from (fewer than ``train_freq`` steps' updates)."""

    def __init__(self, total: int, start: int) -> None:
        super().__init__()
        self.total, self.start = total, start

    def _on_step(self) -> bool:
        frequency = self.model.train_freq
        chunk = frequency.frequency * self.training_env.num_envs if frequency.unit == TrainFrequencyUnit.STEP else None
        at_chunk_end = chunk is not None and (self.num_timesteps - self.start) % chunk == 0
        return self.num_timesteps < self.total or at_chunk_end


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
            cli.write_whole(self.run_dir / "best_model.json", json.dumps(score, indent=2))
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
    cli.write_whole(run_dir / "run.json", json.dumps(record, indent=2))


def build_model(config: dict[str, Any], train_env: VecEnv, resume_from: Path | None) -> BaseAlgorithm:
    """A new model from the hyperparameters, or the checkpoint ``resume_from`` with its buffer."""
    algo, hp = config["algo"], dict(config["hyperparams"])
    policy = hp.get("policy", policy_of(algo))
    hp = {k: v for k, v in hp.items() if k not in RUN_KEYS}
    if resume_from is None:
        where = f"{config['hyperparams_file']} [{config['env']}]"
        try:
            kwargs = algo_kwargs(hp, train_env.action_space.shape[0])
            return ALGOS[algo](policy, train_env, seed=config["seed"], device="cpu", verbose=0, **kwargs)
        except (TypeError, ValueError, KeyError, AssertionError) as err:  # an unknown or malformed hyperparameter
            raise ValueError(f"{where}: {algo} does not accept these hyperparameters ({err})") from err
    model = ALGOS[algo].load(resume_from, env=train_env, device="cpu")
    buffer = resume_from.with_name(f"{CHECKPOINT_PREFIX}_replay_buffer_{checkpoint_steps(resume_from)}_steps.pkl")
    if buffer.is_file():
        model.load_replay_buffer(buffer)
    return model


@dataclass
class Setup:
    """A session's envs and model, made before anything is written (see :func:`prepare`)."""

    model: BaseAlgorithm
    train_env: VecEnv
    eval_env: VecEnv
    resumed_from: Path | None

    def close(self) -> None:
        self.train_env.close()
        self.eval_env.close()


def prepare(config: dict[str, Any], resume_dir: Path | None = None) -> Setup:
    """The envs and the model: new, or continuing the run in ``resume_dir`` from its newest
    checkpoint that loads. Nothing is written, so whatever the algorithm refuses is refused
    before the run has a folder (or ``runs/latest`` points at one)."""
    algo, env_id, seed = config["algo"], config["env"], config["seed"]
    hp = config["hyperparams"]
    n_envs, normalize, gamma = int(hp.get("n_envs", 1)), normalize_kwargs(hp.get("normalize", False)), hp.get("gamma", 0.99)
    resume_from = resumable_checkpoint(resume_dir, hp) if resume_dir is not None else None
    offset = resume_point(resume_dir, config, resume_from) if resume_from else 0
    total = whole_rollouts(algo, int(hp["n_timesteps"]), hp)
    if resume_from is not None and offset >= total:
        raise ValueError(f"{resume_dir} has trained its {offset} steps: give --timesteps above {offset} to extend it")
    one_thread_per_process()
    set_random_seed(seed)

    # A resumed run draws new episodes: reseed by the step count it continues from; it continues
    # the checkpoint's normalisation statistics (under the frame stack, if there is one).
    statistics = normalizer_path(resume_from) if resume_from is not None and normalize is not None else None
    train_env = make_env(env_id, n_envs, seed + offset, config["vec_env"], normalize, gamma, training=True,
                         frame_stack=frame_stack_of(hp), statistics=statistics, residual=residual_of(hp),
                         shaping=shaping_of(hp))
    # Every selection episode in one batch, one per environment: a step of the evaluation is one
    # call of the vector env and one of the policy, and episode i is reset(seed=eval seed + i) alone.
    eval_env = make_env(env_id, config["eval_episodes"], seed + EVAL_SEED_OFFSET, "batched", normalize, gamma,
                        training=False, frame_stack=frame_stack_of(hp), residual=residual_of(hp),
                        shaping=shaping_of(hp))
    try:
        model = build_model(config, train_env, resume_from)
    except BaseException:
        train_env.close()
        eval_env.close()
        raise
    if resume_from is not None and offset != checkpoint_steps(resume_from):
        print(f"resuming {resume_from.name} at {offset:,} steps, the end of the last rollout it learnt from "
              f"({algo} learns from whole rollouts of {rollout_steps(algo, hp):,} steps)", flush=True)
    model.num_timesteps = offset
    return Setup(model, train_env, eval_env, resume_from)


def run_session(setup: Setup, config: dict[str, Any], run_dir: Path, command: str, progress_bar: bool = False,
                on_evaluation: EvaluationHook | None = None) -> dict[str, Any]:
    """Train ``setup``'s model in ``run_dir`` (made if missing) to the budget; the session record.
    Closes the envs."""
    model, seed, n_envs = setup.model, config["seed"], int(config["hyperparams"].get("n_envs", 1))
    total = whole_rollouts(config["algo"], int(config["hyperparams"]["n_timesteps"]), config["hyperparams"])
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        model.tensorboard_log = str(run_dir / "tb")
        callbacks: list[BaseCallback] = [StopOnSignal()]
        if config["save_freq"] > 0:
            callbacks.append(CheckpointCallback(max(config["save_freq"] // n_envs, 1), str(run_dir / "checkpoints"),
                                                CHECKPOINT_PREFIX, save_replay_buffer=True, save_vecnormalize=True))
        evaluator = None
        if config["eval_freq"] > 0:
            setup.eval_env.seed(seed + EVAL_SEED_OFFSET)
            evaluator = EvalOnTotalSteps(
                setup.eval_env, max(config["eval_freq"] // n_envs, 1) * n_envs, n_eval_episodes=config["eval_episodes"],
                log_path=str(run_dir), best_model_save_path=None, deterministic=True, verbose=0,
                callback_after_eval=KeepBestBySuccess(run_dir, seed + EVAL_SEED_OFFSET, on_evaluation))
            if setup.resumed_from is not None:
                continue_history(evaluator, run_dir / "evaluations.npz", model.num_timesteps)
            callbacks.append(evaluator)
        if config["algo"] not in ON_POLICY:
            callbacks.append(StopAtBudget(total, model.num_timesteps))

        sessions = read_run(run_dir)["sessions"] if setup.resumed_from else []
        session = {"command": command, "status": "running", "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                   "start_timesteps": model.num_timesteps}
        sessions.append(session)
        write_run_json(run_dir, config, sessions)
        start, status = time.perf_counter(), "finished"
        try:
            model.learn(total - model.num_timesteps, callback=callbacks, tb_log_name="tb",
                        reset_num_timesteps=setup.resumed_from is None, progress_bar=progress_bar)
            if stop_requested() is not None and model.num_timesteps < total:  # a signal in the last step: finished
                status = "interrupted"
            elif evaluator is not None:
                evaluator.evaluate_final()
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
        setup.close()
    return session


def selection_history(run_dir: Path) -> list[tuple[int, float]]:
    """A run's learning curve: (env steps, success rate on the selection episodes) at every
    evaluation in its ``evaluations.npz`` (train.py's) or its ``run.json``'s ``curve`` (train_jax.py's:
    the same fresh episodes of the JAX env after every chunk); empty if it has none (no evaluation, or an
    older run that did not record successes)."""
    log = Path(run_dir) / "evaluations.npz"
    if not log.is_file():
        record = Path(run_dir) / "run.json"
        curve = json.loads(record.read_text()).get("curve", []) if record.is_file() else []
        return [(int(steps), float(rate)) for steps, rate in curve]
    with np.load(log) as history:
        if "successes" not in history:
            return []
        return [(int(steps), float(np.mean(successes)))
                for steps, successes in zip(history["timesteps"], history["successes"])]


def continue_history(evaluator: EvalCallback, log: Path, resumed_at: int) -> None:
    """Give a resumed run's EvalCallback the evaluations up to its checkpoint: it starts
    ``evaluations.npz`` afresh, and a resumed run's learning curve lost everything before the resume.
    Evaluations after the checkpoint (the interrupted session's last ones) are played again."""
    if not log.is_file():
        return
    with np.load(log) as past:
        kept = past["timesteps"] <= resumed_at
        evaluator.evaluations_timesteps = past["timesteps"][kept].tolist()
        evaluator.evaluations_results = past["results"][kept].tolist()
        evaluator.evaluations_length = past["ep_lengths"][kept].tolist()
        if "successes" in past:
            evaluator.evaluations_successes = past["successes"][kept].tolist()


def train(config: dict[str, Any], run_dir: Path, command: str, resume: bool = False, progress_bar: bool = False,
          on_evaluation: EvaluationHook | None = None) -> dict[str, Any]:
    """Train (or, with ``resume``, continue) the run ``config`` in ``run_dir``; the session record.

    Ctrl-C or SIGTERM (see :func:`stop_on_signals`) save a checkpoint and end the session as
    ``interrupted``; an exception from ``on_evaluation`` propagates after the run is recorded.
    """
    return run_session(prepare(config, run_dir if resume else None), config, run_dir, command, progress_bar,
                       on_evaluation)


def header(config: dict[str, Any], run_dir: Path, resume: bool) -> str:
    """What is about to run, before it runs."""
    hp = config["hyperparams"]
    total, asked = whole_rollouts(config["algo"], int(hp["n_timesteps"]), hp), int(hp["n_timesteps"])
    budget = f"{asked:,} steps" + (f" (whole rollouts: {total:,})" if total != asked else "")
    return (f"{'resuming' if resume else 'training'} {config['algo']} on {config['env']}, seed {config['seed']}, "
            f"{budget}, {hp.get('n_envs', 1)} envs ({config['vec_env']}), hyperparameters "
            f"{config['hyperparams_file']} -> {run_dir}")


def check_run_folder(args: argparse.Namespace) -> None:
    """Refuse now, not after the header: a folder that holds a run already, or where nothing can
    be written (under a regular file, read-only)."""
    if args.resume is not None:
        for folder in (args.resume, args.resume / "checkpoints"):
            cli.check_writable_dir(folder, "--resume")
    elif args.out is not None:
        if (args.out / "run.json").exists():
            raise ValueError(f"{args.out} holds a run already: --resume {args.out} continues it, or choose another --out")
        cli.check_writable_dir(args.out, "--out")
    else:
        cli.check_writable_dir(RUNS_ROOT, "the default --out")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    try:
        args = parse_args(argv)
        config, notes = run_config(args)
        check_hyperparams(config)
        check_run_folder(args)
        setup = prepare(config, args.resume)
    except (ModelLoadError, ValueError) as err:  # cli.UsageError is a ValueError
        return cli.fail(err)
    # Only now, with everything checked and the model built, is anything written.
    try:
        run_dir = args.resume or args.out or new_run_dir(config["env"], config["algo"], config["seed"])
    except OSError as err:  # the folder changed since it was checked
        setup.close()
        return cli.fail(f"cannot create the run folder ({err})")
    print("\n".join([*notes, header(config, run_dir, args.resume is not None)]), flush=True)
    try:
        if args.resume is None and args.out is None:
            point_latest(run_dir)
        session = run_session(setup, config, run_dir, shlex.join(["python", "train.py", *argv]),
                              progress_bar=not args.no_progress_bar and sys.stderr.isatty())
    except OSError as err:  # writable when checked, but not now (disk full, removed): keep what was written
        return cli.fail(f"{run_dir}: {err} (the files written before it are kept)")
    status = session["status"]
    print(f"{status}: {session['timesteps']:,} steps in {session['wall_time_s']:.0f} s -> {run_dir}")
    if status == "interrupted":
        print(f"continue with: python train.py --resume {run_dir}")
        return 130
    return 0


#: The signal that asked the process to stop (see :func:`stop_on_signals`), or None.
_stop: dict[str, str | None] = {"requested": None}


def stop_requested() -> str | None:
    """The name of the signal that asked this process to stop, or None."""
    return _stop["requested"]


class StopOnSignal(BaseCallback):
    """Ends ``model.learn`` at the next env step once a signal asked to stop.

    The signal handler itself never raises on the first signal: raised wherever Python happens
    to be, a KeyboardInterrupt broke torch's zip writer in the middle of a checkpoint, and one
    that landed inside ``loss.backward`` ended a tuning trial with a RuntimeError.
    """

    def _on_step(self) -> bool:
        return _stop["requested"] is None


def stop_on_signals() -> None:
    """SIGINT and SIGTERM (a scheduler's pre-emption) both save a checkpoint and stop, at the
    next env step; a second signal aborts at once (KeyboardInterrupt, no checkpoint promised).

    A shell without job control starts background jobs with SIGINT ignored, and Python
    then never raises KeyboardInterrupt: restore it explicitly.
    """
    def interrupt(signum: int, frame: object) -> None:
        name = signal.Signals(signum).name
        if _stop["requested"] is not None:
            raise KeyboardInterrupt(name)
        _stop["requested"] = name
        print(f"{name}: stopping at the next step with a checkpoint (again to abort)", file=sys.stderr, flush=True)

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, interrupt)


@contextlib.contextmanager
def stopping_on_signals() -> Iterator[None]:
    """:func:`stop_on_signals` for the block, then the handlers and the stop request as they were:
    a command's ``main`` called in-process (a test, a notebook) leaves its caller's Ctrl-C alone."""
    previous = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    requested = _stop["requested"]
    stop_on_signals()
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        _stop["requested"] = requested
