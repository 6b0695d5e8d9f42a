"""The passive sail: the beam stays centred on the target line and is never steered."""

from __future__ import annotations

import numpy as np

from agents.base import check_observation
from sail_env.core.spec import EpisodeSpec


class PassiveAgent:
    """Always commands zero beam offset and tilt."""

    name = "passive"

    def __init__(self, spec: EpisodeSpec) -> None:
        self.spec, self.n_inputs = spec, len(spec.action_scale)

    def act(self, observation: np.ndarray) -> np.ndarray:
        check_observation(self.spec, observation, self.name)
        return np.zeros((*np.shape(observation)[:-1], self.n_inputs), dtype=np.float32)

    def reset(self) -> None:
        """Nothing to forget."""
