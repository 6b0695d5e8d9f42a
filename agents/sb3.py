"""Stable-Baselines3 glue: hyperparameter files, file layout of a run, trained agents.

A run directory (``train.py --out DIR``) holds, for every saved model ``NAME.zip``, the
``VecNormalize`` statistics it was trained with in ``NAME_vecnormalize.pkl``
(checkpoints follow SB3's own naming, ``rl_model_vecnormalize_<N>_steps.pkl``).
:meth:`SB3Agent.load` finds them from the model path.
"""

from __future__ import annotations

import pickle
import re
from pathlib import Path
from typing import Any

import numpy as np
import torch
import yaml
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

from sail_env.provenance import package_versions

ALGOS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "sac": SAC, "td3": TD3}
#: The policy class stored in a model file tells which algorithm trained it.
_POLICY_ALGOS = ((ActorCriticPolicy, "ppo"), (SACPolicy, "sac"), (TD3Policy, "td3"))
HYPERPARAMS_DIR = Path(__file__).parent / "hyperparams"
_ACTIVATIONS = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU, "elu": torch.nn.ELU}
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
        raise ValueError(f"{path}: cannot read hyperparameters ({type(err).__name__})") from err
    if not isinstance(table, dict) or env_id not in table:
        known = sorted(table) if isinstance(table, dict) else []
        raise ValueError(f"{path}: no entry for {env_id!r} (has {known})")
    return dict(table[env_id])


def policy_kwargs(value: str | dict[str, Any] | None) -> dict[str, Any]:
    """``policy_kwargs`` from YAML: a dict, or a Zoo-style string ``"dict(net_arch=[64, 64])"``.

    ``activation_fn`` may be a name (``tanh``, ``relu``, ``elu``) or ``nn.Tanh`` in a string.
    """
    if value is None:
        return {}
    if isinstance(value, str):
        value = eval(value, {"__builtins__": {}}, {"dict": dict, "nn": torch.nn})  # noqa: S307 (Zoo format)
    kwargs = dict(value)
    activation = kwargs.get("activation_fn")
    if isinstance(activation, str):
        if activation.lower() not in _ACTIVATIONS:
            raise ValueError(f"activation_fn must be one of {sorted(_ACTIVATIONS)}, got {activation!r}")
        kwargs["activation_fn"] = _ACTIVATIONS[activation.lower()]
    return kwargs


def algo_kwargs(hyperparams: dict[str, Any], n_actions: int) -> dict[str, Any]:
    """Keyword arguments of the algorithm from the rest of a YAML entry.

    Parses ``policy_kwargs``, the Zoo's linear schedules (``learning_rate: lin_3e-4``
    decays to 0 over training) and turns ``noise_type: normal`` + ``noise_std`` into an
    ``action_noise``.
    """
    kwargs = dict(hyperparams)
    for key in ("learning_rate", "clip_range"):
        value = kwargs.get(key)
        if isinstance(value, str) and value.startswith("lin_"):
            kwargs[key] = LinearSchedule(float(value.removeprefix("lin_")), 0.0, 1.0)
    kwargs["policy_kwargs"] = policy_kwargs(kwargs.get("policy_kwargs"))
    noise_type, noise_std = kwargs.pop("noise_type", None), kwargs.pop("noise_std", 0.1)
    if noise_type is not None:
        if noise_type != "normal":
            raise ValueError(f"noise_type must be 'normal', got {noise_type!r}")
        kwargs["action_noise"] = NormalActionNoise(np.zeros(n_actions), noise_std * np.ones(n_actions))
    return kwargs


def normalize_kwargs(value: bool | str | dict[str, Any]) -> dict[str, Any] | None:
    """``normalize`` from YAML: ``true``, ``false`` or VecNormalize kwargs (dict or Zoo string)."""
    if isinstance(value, str):
        value = eval(value, {"__builtins__": {}}, {"dict": dict})  # noqa: S307 (Zoo format)
    if value is False:
        return None
    return {} if value is True else dict(value)


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


def algo_of(model_path: str | Path) -> str:
    """The algorithm (``ppo``, ``sac``, ``td3``) that wrote a model file."""
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
    """Versions of Python and the packages a result depends on."""
    packages = ("lightsail-gym", "stable-baselines3", "torch", "gymnasium", "numpy", "scipy")
    return package_versions(*packages)


# ---------------------------------------------------------------------- trained agents
class SB3Agent:
    """A trained SB3 model behind the :class:`~agents.base.Agent` interface (deterministic)."""

    def __init__(self, model: BaseAlgorithm, normalizer: VecNormalize | None, name: str) -> None:
        self.model, self.normalizer, self.name = model, normalizer, name

    @classmethod
    def load(cls, path: str | Path, observation_shape: tuple[int, ...] | None = None) -> SB3Agent:
        """Load ``path`` and the normaliser saved beside it; :class:`ModelLoadError` if unusable."""
        path = Path(path)
        if not path.is_file():
            raise ModelLoadError(f"{path}: model file not found")
        algo = algo_of(path)
        try:
            model = ALGOS[algo].load(path, device="cpu")
        except Exception as err:
            raise ModelLoadError(f"{path}: cannot load {algo} model ({type(err).__name__}: {err})") from err
        if observation_shape is not None and model.observation_space.shape != tuple(observation_shape):
            raise ModelLoadError(f"{path}: trained on observations of shape {model.observation_space.shape}, "
                                 f"this env has {tuple(observation_shape)}")
        stats = normalizer_path(path)
        normalizer = None
        if stats.is_file():
            try:
                with stats.open("rb") as file:
                    normalizer = pickle.load(file)  # what VecNormalize.load does, without a venv
            except Exception as err:
                raise ModelLoadError(f"{stats}: cannot load normaliser ({type(err).__name__})") from err
            normalizer.training = False
        return cls(model, normalizer, f"{algo}:{path.parent.name}/{path.stem}")

    def act(self, observation: np.ndarray) -> np.ndarray:
        if self.normalizer is not None:
            observation = self.normalizer.normalize_obs(observation)
        action, _ = self.model.predict(observation, deterministic=True)
        return action

    def reset(self) -> None:
        """Feed-forward policy: nothing to forget."""
