"""Stable-Baselines3 glue: hyperparameter files, file layout of a run, trained agents.

A run directory (``train.py --out DIR``) holds, for every saved model ``NAME.zip``, the
``VecNormalize`` statistics it was trained with in ``NAME_vecnormalize.pkl``
(checkpoints follow SB3's own naming, ``rl_model_vecnormalize_<N>_steps.pkl``).
:meth:`SB3Agent.load` finds them from the model path, and the run's ``run.json`` tells it
whether the model needs them, how many observations it sees at once (``frame_stack``) and
which env it was trained on.
"""

from __future__ import annotations

import json
import math
import pickle
import re
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml
from sb3_contrib import RecurrentPPO
from sb3_contrib.common.recurrent.policies import RecurrentActorCriticPolicy
from stable_baselines3 import PPO, SAC, TD3
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.noise import NormalActionNoise
from stable_baselines3.common.policies import ActorCriticPolicy
from stable_baselines3.common.save_util import load_from_zip_file
from stable_baselines3.common.utils import LinearSchedule
from stable_baselines3.common.vec_env import VecNormalize
from stable_baselines3.sac.policies import SACPolicy
from stable_baselines3.td3.policies import TD3Policy
from threadpoolctl import threadpool_limits

from agents import zoo_syntax
from agents.residual import residual_of
from sail_env.physics.blas import blas_libraries
from sail_env.provenance import package_versions

ALGOS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "recurrent_ppo": RecurrentPPO, "sac": SAC, "td3": TD3}
#: The algorithms that collect rollouts of ``n_steps`` × ``n_envs`` (train whole rollouts).
ON_POLICY = frozenset({"ppo", "recurrent_ppo"})
#: The policy each algorithm trains (the observations are a flat vector); ``MlpPolicy`` otherwise.
POLICIES = {"recurrent_ppo": "MlpLstmPolicy"}
#: The policy class stored in a model file tells which algorithm trained it (a subclass before its base).
_POLICY_ALGOS = ((RecurrentActorCriticPolicy, "recurrent_ppo"), (ActorCriticPolicy, "ppo"), (SACPolicy, "sac"),
                 (TD3Policy, "td3"))
HYPERPARAMS_DIR = Path(__file__).parent / "hyperparams"
#: Hyperparameters that may be a schedule (``lin_<number>``).
SCHEDULES = ("learning_rate", "clip_range")
#: What ``normalize`` may set (``gamma`` comes from the algorithm's).
NORMALIZE_KEYS = frozenset({"norm_obs", "norm_reward", "clip_obs", "clip_reward", "epsilon"})
_CHECKPOINT = re.compile(r"^(?P<prefix>.+)_(?P<steps>\d+)_steps$")


class ModelLoadError(Exception):
    """A model or its normaliser cannot be used; the message is one line naming the file."""


# ---------------------------------------------------------------------- hyperparameters
def load_hyperparams(algo: str, env_id: str, path: str | Path | None = None) -> dict[str, Any]:
    """The entry for ``env_id`` in a Zoo-style YAML file (default ``hyperparams/<algo>.yml``)."""
    path = Path(path) if path is not None else HYPERPARAMS_DIR / f"{algo}.yml"
    try:
        table = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as err:
        raise ValueError(f"{path}: cannot read hyperparameters ({yaml_problem(err)})") from err
    if not isinstance(table, dict) or env_id not in table:
        known = sorted(table) if isinstance(table, dict) else []
        raise ValueError(f"{path}: no entry for {env_id!r} (has {known})")
    entry = table[env_id]
    if not isinstance(entry, dict):
        raise ValueError(f"{path} [{env_id}]: the entry must be a mapping of hyperparameters (key: value lines), "
                         f"got {type(entry).__name__} {entry!r}")
    return dict(entry)


def yaml_problem(err: Exception) -> str:
    """What went wrong reading a file, and where for a YAML error: ``ParserError: expected <block end>,
    but found '<block mapping start>' at line 4, column 3``."""
    mark = getattr(err, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
    problem = getattr(err, "problem", None) or getattr(err, "strerror", None)
    return f"{type(err).__name__}: {problem}{where}" if problem else type(err).__name__


def policy_kwargs(value: str | dict[str, Any] | None) -> dict[str, Any]:
    """``policy_kwargs`` from YAML: a dict, or a Zoo-style string ``"dict(net_arch=[64, 64])"``
    (read by :func:`agents.zoo_syntax.parse`, never executed).

    ``activation_fn`` may be ``nn.Tanh`` in a string or a name (``tanh``, ``relu``, ...).
    """
    if value is None:
        return {}
    if isinstance(value, str):
        value = zoo_syntax.parse(value, "policy_kwargs")
    if not isinstance(value, dict):
        raise ValueError(f"policy_kwargs must be a mapping or 'dict(...)', got {value!r}")
    kwargs = dict(value)
    if "activation_fn" in kwargs:
        kwargs["activation_fn"] = zoo_syntax.activation(kwargs["activation_fn"], "policy_kwargs.activation_fn")
    return kwargs


def schedule(key: str, value: Any) -> float | LinearSchedule:
    """A number, or the Zoo's ``lin_<number>``: from that value down to 0 over training."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return value
    if isinstance(value, str) and value.startswith("lin_"):
        try:
            start = float(value.removeprefix("lin_"))
        except ValueError:
            start = math.nan
        if math.isfinite(start):
            return LinearSchedule(start, 0.0, 1.0)
    raise ValueError(f"{key} must be a finite number (YAML reads 3e-4 as text: write 3.0e-4) "
                     f"or lin_<number>, got {value!r}")


def algo_kwargs(hyperparams: dict[str, Any], n_actions: int) -> dict[str, Any]:
    """Keyword arguments of the algorithm from the rest of a YAML entry.

    Parses ``policy_kwargs``, the Zoo's linear schedules (``learning_rate: lin_3e-4``
    decays to 0 over training) and turns ``noise_type: normal`` + ``noise_std`` into an
    ``action_noise``.
    """
    kwargs = dict(hyperparams)
    for key in SCHEDULES:
        if key in kwargs:
            kwargs[key] = schedule(key, kwargs[key])
    kwargs["policy_kwargs"] = policy_kwargs(kwargs.get("policy_kwargs"))
    noise_type, noise_std = kwargs.pop("noise_type", None), kwargs.pop("noise_std", 0.1)
    if noise_type is not None:
        if noise_type != "normal":
            raise ValueError(f"noise_type must be 'normal', got {noise_type!r}")
        kwargs["action_noise"] = NormalActionNoise(np.zeros(n_actions), noise_std * np.ones(n_actions))
    return kwargs


def normalize_kwargs(value: bool | str | dict[str, Any]) -> dict[str, Any] | None:
    """``normalize`` from YAML: ``true``, ``false`` or VecNormalize kwargs (a mapping or a Zoo
    string ``"dict(norm_obs=True, norm_reward=False)"``, read by :func:`agents.zoo_syntax.parse`)."""
    if isinstance(value, str):
        value = zoo_syntax.parse(value, "normalize")
    if isinstance(value, bool):
        return {} if value else None
    if not isinstance(value, dict) or not set(value) <= NORMALIZE_KEYS:
        raise ValueError(f"normalize must be true, false or a mapping of {sorted(NORMALIZE_KEYS)}, got {value!r}")
    return dict(value)


def policy_of(algo: str) -> str:
    """The policy ``algo`` trains on this env's flat observations."""
    return POLICIES.get(algo, "MlpPolicy")


def frame_stack_of(hyperparams: dict[str, Any]) -> int:
    """How many observations the policy sees at once (``frame_stack``; 1: the newest only)."""
    return int(hyperparams.get("frame_stack", 1))


def unstacked_shape(shape: tuple[int, ...], frame_stack: int) -> tuple[int, ...]:
    """The env's observation shape under a model's ``frame_stack`` observations stacked along the last axis."""
    return (*shape[:-1], shape[-1] // frame_stack)


# ---------------------------------------------------------------------- files
def normalizer_path(model_path: str | Path) -> Path:
    """Where the VecNormalize statistics of a saved model live."""
    model_path = Path(model_path)
    stem = model_path.name.removesuffix(".zip")
    match = _CHECKPOINT.match(stem)
    if match:
        return model_path.with_name(f"{match['prefix']}_vecnormalize_{match['steps']}_steps.pkl")
    return model_path.with_name(f"{stem}_vecnormalize.pkl")


def save_model(model: BaseAlgorithm, path: Path) -> None:
    """Save ``model`` to ``path`` (a ``.zip``) with its normaliser beside it, if it has one."""
    model.save(path)
    normalizer = model.get_vec_normalize_env()
    if normalizer is not None:
        normalizer.save(normalizer_path(path))


def run_record(model_path: str | Path) -> tuple[Path, dict[str, Any]] | None:
    """``run.json`` and its ``config`` for a model train.py saved: in the model's folder, or the
    one above (``checkpoints/``); ``None`` if neither has one."""
    model_path = Path(model_path)
    for folder in (model_path.parent, model_path.parent.parent):
        record = folder / "run.json"
        if record.is_file():
            try:
                config = json.loads(record.read_text())["config"]
            except (OSError, ValueError, KeyError, TypeError) as err:
                raise ModelLoadError(f"{record}: not a readable run record ({type(err).__name__})") from err
            if not isinstance(config, dict):
                raise ModelLoadError(f"{record}: not a readable run record (config is not a mapping)")
            return record, config
    return None


def load_normalizer(path: Path, observation_shape: tuple[int, ...]) -> VecNormalize:
    """VecNormalize statistics saved by :func:`save_model`, frozen, for observations of ``observation_shape``."""
    try:
        with path.open("rb") as file:
            normalizer = pickle.load(file)  # what VecNormalize.load does, without a venv
    except Exception as err:
        raise ModelLoadError(f"{path}: cannot load normaliser ({type(err).__name__})") from err
    if not isinstance(normalizer, VecNormalize):
        raise ModelLoadError(f"{path}: not VecNormalize statistics ({type(normalizer).__name__})")
    shape = np.shape(getattr(normalizer.obs_rms, "mean", None))
    if normalizer.norm_obs and shape != tuple(observation_shape):
        raise ModelLoadError(f"{path}: statistics of observations of shape {shape}, the model's have shape "
                             f"{tuple(observation_shape)} (statistics of another env?)")
    normalizer.training = False
    return normalizer


def algo_of(model_path: str | Path) -> str:
    """The algorithm (a key of :data:`ALGOS`) that wrote a model file."""
    try:
        data, _, _ = load_from_zip_file(model_path, device="cpu", print_system_info=False)
    except Exception as err:  # SB3 raises many types for a damaged zip
        raise ModelLoadError(f"{model_path}: not a readable Stable-Baselines3 model ({type(err).__name__})") from err
    policy_class = (data or {}).get("policy_class")
    for base, algo in _POLICY_ALGOS:
        if isinstance(policy_class, type) and issubclass(policy_class, base):
            return algo
    raise ModelLoadError(f"{model_path}: unknown policy class {policy_class!r}")


def one_thread_per_process() -> None:
    """Run torch and BLAS on one thread: the env's matrices are tiny, and BLAS threads spinning
    against a second job on a 2-core machine halved the env's steps/s (measured with the former benchmarks/throughput.py)."""
    torch.set_num_threads(1)
    threadpool_limits(1)


def versions() -> dict[str, str]:
    """Versions of Python and the packages a result depends on, and the BLAS kernels: training's
    numbers change with OpenBLAS's kernel (docs/learners.md, "Reliability")."""
    packages = ("lightsail-gym", "stable-baselines3", "sb3-contrib", "torch", "gymnasium", "numpy", "scipy")
    blas = "; ".join(f"{lib.internal_api} {lib.version} {lib.architecture}" for lib in blas_libraries())
    return {**package_versions(*packages), "blas": blas}


# ---------------------------------------------------------------------- trained agents
class SB3Agent:
    """A trained SB3 model behind the :class:`~agents.base.Agent` interface (deterministic).

    ``trained_env`` is the env id its run was trained on (from ``run.json``), if known. A model
    trained with ``frame_stack`` k > 1 sees what VecFrameStack showed it: the last k normalised
    observations of each env side by side, oldest first, zeros before the episode's first. A
    recurrent policy (``recurrent_ppo``) carries its LSTM state from step to step and starts it
    afresh at an episode's first step, as in training.
    """

    def __init__(self, model: BaseAlgorithm, normalizer: VecNormalize | None, name: str,
                 trained_env: str | None = None, frame_stack: int = 1,
                 residual: tuple[str, float] | None = None) -> None:
        self.model, self.normalizer, self.name, self.trained_env = model, normalizer, name, trained_env
        self.frame_stack = frame_stack
        self.residual = residual  # (base, scale) of a residual policy: it sees augmented observations
        self.history: np.ndarray | None = None  # the stacked observations; None until an episode's first
        self.memory: tuple[np.ndarray, ...] | None = None  # a recurrent policy's state; None at an episode's start

    @classmethod
    def load(cls, path: str | Path, observation_shape: tuple[int, ...] | None = None,
             raw_observations_ok: bool = False) -> SB3Agent:
        """Load ``path`` and the normaliser saved beside it; :class:`ModelLoadError` if unusable.

        Whether the model needs VecNormalize statistics comes from its run's ``run.json``
        (:func:`run_record`); needed and missing, or unneeded and present, is refused.
        Without a ``run.json`` statistics beside the model are used; if there are none the
        model is refused unless ``raw_observations_ok`` (a model trained with VecNormalize
        on raw observations points far worse, silently). Both files are unpickled: they run
        code when loaded, so load only files from a trusted source.
        """
        path = Path(path)
        if not path.is_file():
            raise ModelLoadError(f"{path}: model file not found")
        # runs/latest/best_model.zip is named (and recorded) by the run the link points at now.
        run_name = path.resolve().parent.name
        algo = algo_of(path)
        stats, record, frame_stack, residual = normalizer_path(path), run_record(path), 1, None
        if record is not None:
            record_path, config = record
            try:
                normalised = normalize_kwargs(config["hyperparams"].get("normalize", False)) is not None
                frame_stack = frame_stack_of(config["hyperparams"])
                residual = residual_of(config["hyperparams"])
            except (KeyError, AttributeError, TypeError, ValueError) as err:
                raise ModelLoadError(f"{record_path}: no readable hyperparams.normalize/frame_stack/residual "
                                     f"({err})") from err
            if normalised != stats.is_file():
                raise ModelLoadError(f"{stats}: {'not found' if normalised else 'unexpected'}; {record_path} says the "
                                     f"model was trained {'with' if normalised else 'without'} VecNormalize")
        elif not stats.is_file() and not raw_observations_ok:
            raise ModelLoadError(f"{stats}: not found, and no run.json beside {path.name} says whether it was trained "
                                 "with VecNormalize (evaluate.py --raw-observations: it was not)")
        try:
            model = ALGOS[algo].load(path, device="cpu")
        except Exception as err:
            raise ModelLoadError(f"{path}: cannot load {algo} model ({type(err).__name__}: {err})") from err
        shape = model.observation_space.shape
        trained_env = record[1].get("env") if record is not None else None
        if observation_shape is not None and residual is not None:  # the env's observation and the base's action
            observation_shape = (*observation_shape[:-1], observation_shape[-1] + model.action_space.shape[0])
        if observation_shape is not None and shape != (*observation_shape[:-1], observation_shape[-1] * frame_stack):
            hint = f"; this model was trained on {trained_env}: pass --env {trained_env}" if trained_env else ""
            stacked = f" ({frame_stack} stacked)" if frame_stack > 1 else ""
            raise ModelLoadError(f"{path}: trained on observations of shape {shape}{stacked}, "
                                 f"this env has {tuple(observation_shape)}{hint}")
        normalizer = load_normalizer(stats, unstacked_shape(shape, frame_stack)) if stats.is_file() else None
        return cls(model, normalizer, f"{algo}:{run_name}/{path.stem}", trained_env, frame_stack, residual)

    def act(self, observation: np.ndarray) -> np.ndarray:
        """The action for one observation (D,) or a batch (N, D) of episodes started together."""
        if self.normalizer is not None:
            observation = self.normalizer.normalize_obs(observation)
        if self.frame_stack > 1:
            if self.history is None:
                self.history = np.zeros((*observation.shape[:-1], observation.shape[-1] * self.frame_stack),
                                        self.model.observation_space.dtype)
            # VecFrameStack's order: shift out the oldest, the newest last.
            self.history = np.concatenate([self.history[..., observation.shape[-1]:], observation], axis=-1,
                                          dtype=self.history.dtype)
            observation = self.history
        if not isinstance(self.model, RecurrentPPO):
            action, _ = self.model.predict(observation, deterministic=True)
            return action
        starts = np.full(observation.shape[:-1] or (1,), self.memory is None)
        action, self.memory = self.model.predict(observation, state=self.memory, episode_start=starts,
                                                 deterministic=True)
        return action

    def reset(self) -> None:
        """Forget the stacked observations and the recurrent state: the next ``act`` starts an
        episode (or a batch of them)."""
        self.history = self.memory = None
