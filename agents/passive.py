"""The passive sail: the beam stays centred on the target line and is never steered."""

from __future__ import annotations

import gymnasium as gym
import numpy as np


class PassiveAgent:
    """Always commands zero beam offset and tilt."""

    name = "passive"

    def __init__(self, env: gym.Env) -> None:
        self._action = np.zeros(env.action_space.shape, dtype=np.float32)

    def act(self, observation: np.ndarray) -> np.ndarray:
        return self._action.copy()

    def reset(self) -> None:
        """Nothing to forget."""
