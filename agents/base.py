"""The tiny interface every baseline and learner implements."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from sail_env.core.spec import EpisodeSpec


class Agent(Protocol):
    """``act(obs) -> action`` in the env's normalised action space; ``reset()`` between episodes.

    ``act`` takes one observation (D,) or a batch (N, D) of episodes started together.
    """

    name: str

    def act(self, observation: np.ndarray) -> np.ndarray: ...

    def reset(self) -> None: ...


def check_observation(spec: EpisodeSpec, observation: np.ndarray, name: str) -> None:
    """``ValueError`` unless ``observation`` is one (D,) or a batch (N, D) of the task ``spec``'s.

    A controller reads the state from the observation's first entries: given another task's
    observations it acted on them silently (a longer one) or failed in NumPy's broadcasting.
    """
    shape = np.shape(observation)
    if len(shape) not in (1, 2) or shape[-1] != spec.observation_size:
        raise ValueError(f"{name}: built for a task whose observations have {spec.observation_size} entries ((D,) or "
                         f"(N, D)), got shape {shape}: build the agent from the env it acts in")
