"""Train a Stable-Baselines3 agent on a lightsail-gym task (RL Baselines3 Zoo conventions).

    python train.py --algo ppo                        # the defaults: a good PPO on LightSail-v0
    python train.py --algo sac --env LightSailDeepDish-v0 --timesteps 200000 --seed 1
    python train.py --resume runs/LightSail-v0-ppo-0  # continue an interrupted run

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (keyed by env id, or
``--config FILE``); flags override them. Everything goes under ``--out``
(default ``runs/<env>-<algo>-<seed>/``):

    run.json                          versions, seed, configuration, command, status
    best_model.zip (+ _vecnormalize.pkl)   best evaluation success rate (mean return breaks ties)
    best_model.json                   when and how well it was evaluated
    final_model.zip (+ _vecnormalize.pkl)  at the end of training
    checkpoints/rl_model_<N>_steps.zip (+ normaliser, replay buffer)   also written on Ctrl-C or SIGTERM
    evaluations.npz, tb/              evaluation history, TensorBoard logs
"""

from __future__ import annotations

import argparse
import json
import shlex
import signal
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CheckpointCallback, EvalCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.utils import set_random_seed
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv, VecMonitor, VecNormalize

import sail_env  # noqa: F401  (registers the env ids)
from agents.sb3 import (ALGOS, ModelLoadError, algo_kwargs, load_hyperparams, normalize_kwargs,
                        normalizer_path, one_thread_per_process, save_model, versions)
from agents.vec_env import BatchedVecEnv

CHECKPOINT_PREFIX = "rl_model"
#: Evaluation episodes during training are seeded apart from the training envs and from
#: evaluate.py's default seed, so the best model is not selected on the reported episodes.
EVAL_SEED_OFFSET = 10_000
#: Evaluation episodes run this many at a time (the episodes are the same for any number).
EVAL_ENVS = 10


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--algo", choices=sorted(ALGOS), help="required unless --resume")
    parser.add_argument("--env", default="LightSail-v0")
    parser.add_argument("-n", "--timesteps", type=int, help="total training steps (overrides n_timesteps)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--n-envs", type=int, help="parallel training envs (overrides n_envs)")
    parser.add_argument("--vec-env", choices=("batched", "dummy", "subproc"), default="batched",
                        help="batched: all envs in one NumPy batch (LightSailVectorEnv); dummy/subproc: SB3's "
                             "one-env-at-a-time wrappers")
    parser.add_argument("--out", type=Path, help="run directory (default runs/<env>-<algo>-<seed>)")
    parser.add_argument("--config", type=Path, help="Zoo-style hyperparameter YAML keyed by env id")
    parser.add_argument("--resume", type=Path, metavar="DIR", help="continue the run in DIR from its latest checkpoint")
    parser.add_argument("--eval-freq", type=int, default=10_000, help="evaluate every N steps (<= 0: never)")
    parser.add_argument("--eval-episodes", type=int, default=100)
    parser.add_argument("--save-freq", type=int, default=50_000, help="checkpoint every N steps")
    parser.add_argument("--no-progress-bar", action="store_true")
    args = parser.parse_args(argv)
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
        if args.timesteps is not None:
            config["hyperparams"]["n_timesteps"] = args.timesteps
        return config
    hyperparams = load_hyperparams(args.algo, args.env, args.config)
    if args.timesteps is not None:
        hyperparams["n_timesteps"] = args.timesteps
    if args.n_envs is not None:
        hyperparams["n_envs"] = args.n_envs
    return {"algo": args.algo, "env": args.env, "seed": args.seed, "vec_env": args.vec_env,
            "eval_freq": args.eval_freq, "eval_episodes": args.eval_episodes, "save_freq": args.save_freq,
            "hyperparams_file": str(args.config or f"agents/hyperparams/{args.algo}.yml"),
            "hyperparams": hyperparams}


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


def latest_checkpoint(run_dir: Path) -> Path:
    """The checkpoint with the most steps in ``run_dir/checkpoints``."""
    found = sorted((run_dir / "checkpoints").glob(f"{CHECKPOINT_PREFIX}_*_steps.zip"), key=checkpoint_steps)
    if not found:
        raise ModelLoadError(f"{run_dir / 'checkpoints'}: no checkpoint to resume from")
    return found[-1]


def save_checkpoint(model: BaseAlgorithm, run_dir: Path) -> Path:
    """Model, normaliser and replay buffer under the names CheckpointCallback uses."""
    path = run_dir / "checkpoints" / f"{CHECKPOINT_PREFIX}_{model.num_timesteps}_steps.zip"
    save_model(model, path)
    if getattr(model, "replay_buffer", None) is not None:
        model.save_replay_buffer(path.with_name(f"{CHECKPOINT_PREFIX}_replay_buffer_{model.num_timesteps}_steps.pkl"))
    return path


class KeepBestBySuccess(BaseCallback):
    """After each EvalCallback evaluation: keep the model with the best (success rate, mean return).

    Also re-seeds the eval env, so every evaluation plays the same episodes (paired).
    """

    def __init__(self, run_dir: Path, eval_seed: int) -> None:
        super().__init__()
        self.run_dir, self.eval_seed = run_dir, eval_seed
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
        return True


def write_run_json(run_dir: Path, config: dict[str, Any], sessions: list[dict[str, Any]]) -> None:
    """Configuration, versions, and one entry per session (command, status, steps, wall time)."""
    record = {"command": sessions[0]["command"], "config": config, "versions": versions(), "sessions": sessions}
    (run_dir / "run.json").write_text(json.dumps(record, indent=2))


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    try:
        config = run_config(args)
        resume_from = latest_checkpoint(args.resume) if args.resume else None
    except (ModelLoadError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    algo, env_id, seed = config["algo"], config["env"], config["seed"]
    hp = dict(config["hyperparams"])
    run_dir = args.resume or args.out or Path("runs") / f"{env_id}-{algo}-{seed}"
    run_dir.mkdir(parents=True, exist_ok=True)
    one_thread_per_process()
    set_random_seed(seed)

    # ------------------------------------------------------------------ envs
    n_envs, total = int(hp.pop("n_envs", 1)), int(hp.pop("n_timesteps"))
    policy, normalize = hp.pop("policy", "MlpPolicy"), normalize_kwargs(hp.pop("normalize", False))
    gamma = hp.get("gamma", 0.99)
    # A resumed run draws new episodes: reseed by the step count it continues from.
    offset = checkpoint_steps(resume_from) if resume_from else 0
    train_env = make_env(env_id, n_envs, seed + offset, config["vec_env"], normalize, gamma, training=True)
    eval_envs = max(1, min(EVAL_ENVS, config["eval_episodes"]))
    eval_env = make_env(env_id, eval_envs, seed + EVAL_SEED_OFFSET, config.get("vec_env", "batched"), normalize, gamma,
                        training=False)

    # ------------------------------------------------------------------ model
    if resume_from is None:
        model = ALGOS[algo](policy, train_env, seed=seed, device="cpu", verbose=0,
                            tensorboard_log=str(run_dir / "tb"), **algo_kwargs(hp, train_env.action_space.shape[0]))
    else:
        if normalize is not None:
            train_env = VecNormalize.load(str(normalizer_path(resume_from)), train_env.venv)
        model = ALGOS[algo].load(resume_from, env=train_env, device="cpu", tensorboard_log=str(run_dir / "tb"))
        buffer = resume_from.with_name(f"{CHECKPOINT_PREFIX}_replay_buffer_{offset}_steps.pkl")
        if buffer.is_file():
            model.load_replay_buffer(buffer)
        print(f"resuming from {resume_from} at {model.num_timesteps} steps", flush=True)
    callbacks = [
        CheckpointCallback(max(config["save_freq"] // n_envs, 1), str(run_dir / "checkpoints"), CHECKPOINT_PREFIX,
                           save_replay_buffer=True, save_vecnormalize=True),
    ]
    if config["eval_freq"] > 0:
        eval_env.seed(seed + EVAL_SEED_OFFSET)
        callbacks.append(EvalCallback(eval_env, n_eval_episodes=config["eval_episodes"],
                                      eval_freq=max(config["eval_freq"] // n_envs, 1),
                                      log_path=str(run_dir), best_model_save_path=None, deterministic=True, verbose=0,
                                      callback_after_eval=KeepBestBySuccess(run_dir, seed + EVAL_SEED_OFFSET)))

    # ------------------------------------------------------------------ train
    sessions = json.loads((run_dir / "run.json").read_text())["sessions"] if resume_from else []
    session = {"command": shlex.join(["python", "train.py", *argv]), "status": "running",
               "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "start_timesteps": model.num_timesteps}
    sessions.append(session)
    write_run_json(run_dir, config, sessions)
    start, status = time.perf_counter(), "finished"
    try:
        model.learn(max(total - model.num_timesteps, 0), callback=callbacks, tb_log_name="tb",
                    reset_num_timesteps=resume_from is None, progress_bar=not args.no_progress_bar)
    except KeyboardInterrupt:
        status = "interrupted"
        print(f"\ninterrupted: saved {save_checkpoint(model, run_dir)}; continue with --resume {run_dir}")
    if status == "finished":
        save_model(model, run_dir / "final_model.zip")
    wall = time.perf_counter() - start
    session.update(status=status, timesteps=model.num_timesteps, wall_time_s=round(wall, 1))
    write_run_json(run_dir, config, sessions)
    print(f"{status}: {model.num_timesteps} steps in {wall:.0f} s -> {run_dir}")
    train_env.close()
    eval_env.close()
    return 130 if status == "interrupted" else 0


def stop_on_signals() -> None:
    """SIGINT and SIGTERM (a scheduler's pre-emption) both save a checkpoint and stop.

    A shell without job control starts background jobs with SIGINT ignored, and Python
    then never raises KeyboardInterrupt: restore it explicitly.
    """
    def interrupt(signum: int, frame: object) -> None:
        raise KeyboardInterrupt(signal.Signals(signum).name)

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, interrupt)
