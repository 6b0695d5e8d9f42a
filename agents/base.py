"""The tiny interface every baseline and learner implements."""

from __future__ import annotations

from typing import Protocol

import numpy as np


class Agent(Protocol):
    """``act(obs) -> action`` in the env's normalised action space; ``reset()`` between episodes.

    ``act`` takes one observation (D,) or a batch (N, D) of episodes started together.
    """

    name: str

    def act(self, observation: np.ndarray) -> np.ndarray: ...

    def reset(self) -> None: ...
