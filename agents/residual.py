"""Residual policies: a learner that corrects a classical controller instead of replacing it
(residual policy learning: Silver et al. 2018; Johannink et al. 2019).

The learner sees the env's observation with the base controller's action appended, and its action
is a correction: the env receives ``clip(base + scale × correction, −1, 1)``. A fresh policy's mean
correction is near zero, so training starts from the base's success rather than from the passive
sail's, and what is learned is what the base cannot do, e.g. on ``LightSailUncertain-v1`` the
models that the bank of ``lqg-mm`` does not hold. Set in a run's hyperparameters:

| key | meaning |
|---|---|
| ``residual`` | the base: ``lqr``, ``lqg``, ``lqg-mm`` or ``lqg-mm-offset`` (classical agents that read only the observation) |
| ``residual_scale`` | the correction's largest size in action units, in (0, 1]; default 1 |

In training the base runs inside the vector env (:class:`ResidualVecEnv`, below ``VecNormalize``),
one base per batch that forgets the episodes the batch autoresets; in evaluation
:class:`ResidualAgent` runs the same base beside the trained policy. The tasks never truncate, so
SB3 never bootstraps from a terminal observation: its appended base action is left at zero.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

from agents.adaptive import MultipleModelLQGAgent, OffsetFreeMultipleModelLQGAgent
from agents.lqg import LQGAgent
from agents.lqr import LQRAgent
from sail_env.core.spec import EpisodeSpec


class ResettableAgent(Protocol):
    """An :class:`~agents.base.Agent` that can forget some episodes of its batch (``which`` (N,))."""

    name: str

    def act(self, observation: np.ndarray) -> np.ndarray: ...

    def reset(self, which: np.ndarray | None = None) -> None: ...


#: The controllers a residual policy may correct: none reads the simulator's truth.
RESIDUAL_BASES: dict[str, Callable[[EpisodeSpec], ResettableAgent]] = {
    "lqr": LQRAgent, "lqg": LQGAgent, "lqg-mm": MultipleModelLQGAgent, "lqg-mm-offset": OffsetFreeMultipleModelLQGAgent}


def residual_of(hyperparams: dict[str, Any]) -> tuple[str, float] | None:
    """A run's ``(base, scale)``, or None for a policy that acts alone; ``ValueError`` if malformed."""
    base = hyperparams.get("residual")
    if base is None:
        if "residual_scale" in hyperparams:
            raise ValueError("residual_scale needs residual (the base controller's name)")
        return None
    if base not in RESIDUAL_BASES:
        raise ValueError(f"residual must be one of {', '.join(RESIDUAL_BASES)}, got {base!r}")
    scale = hyperparams.get("residual_scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0 < scale <= 1:
        raise ValueError(f"residual_scale must be a number in (0, 1], got {scale!r}")
    return base, float(scale)


def augmented(observation: np.ndarray, base_action: np.ndarray) -> np.ndarray:
    """What the learner sees: the observation with the base's action appended (float32)."""
    return np.concatenate([observation, base_action], axis=-1, dtype=np.float32)


def combined(base_action: np.ndarray, correction: np.ndarray, scale: float) -> np.ndarray:
    """The action the env receives: the base's, corrected, in [−1, 1] (float32)."""
    return np.clip(base_action + scale * np.clip(correction, -1.0, 1.0), -1.0, 1.0).astype(np.float32)


def augmented_space(observation_space: spaces.Box, n_actions: int) -> spaces.Box:
    """The learner's observation space: the env's with ``n_actions`` entries in [−1, 1] appended."""
    low = np.concatenate([observation_space.low, -np.ones(n_actions, np.float32)])
    high = np.concatenate([observation_space.high, np.ones(n_actions, np.float32)])
    return spaces.Box(low, high, dtype=np.float32)


class ResidualVecEnv(VecEnvWrapper):
    """``venv`` as a residual policy's training env: observations augmented, actions corrections."""

    def __init__(self, venv: VecEnv, base: str, scale: float) -> None:
        spec = venv.get_attr("episode_spec", [0])[0]
        self.base, self.scale = RESIDUAL_BASES[base](spec), scale
        super().__init__(venv, observation_space=augmented_space(venv.observation_space, venv.action_space.shape[0]))
        self._base_action: np.ndarray | None = None  # the base's action for the current observations (after reset)

    def reset(self) -> np.ndarray:
        observation = self.venv.reset()
        self.base.reset()
        self._base_action = np.asarray(self.base.act(observation), np.float32)
        return augmented(observation, self._base_action)

    def step_async(self, actions: np.ndarray) -> None:
        self.venv.step_async(combined(self._base_action, actions, self.scale))

    def step_wait(self) -> VecEnvStepReturn:
        observation, rewards, dones, infos = self.venv.step_wait()
        if dones.any():
            self.base.reset(dones)  # the batch has begun new episodes there (SB3's autoreset)
            for i in np.flatnonzero(dones):
                terminal = infos[i].get("terminal_observation")
                if terminal is not None:
                    infos[i]["terminal_observation"] = augmented(terminal, np.zeros_like(self._base_action[i]))
        self._base_action = np.asarray(self.base.act(observation), np.float32)
        return augmented(observation, self._base_action), rewards, dones, infos


class ResidualAgent:
    """A trained residual policy beside its base, behind the :class:`~agents.base.Agent` interface."""

    def __init__(self, learned: Any, base: ResettableAgent, scale: float) -> None:
        self.learned, self.base, self.scale = learned, base, scale
        self.name = f"{learned.name} (residual on {base.name})"

    def act(self, observation: np.ndarray) -> np.ndarray:
        base_action = np.asarray(self.base.act(observation), np.float32)
        return combined(base_action, self.learned.act(augmented(observation, base_action)), self.scale)

    def reset(self) -> None:
        self.base.reset()
        self.learned.reset()
