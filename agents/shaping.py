"""Potential-based reward shaping for training (Ng, Harada & Russell 1999).

The env's reward pays each step's envelope, ``−ρ(envelope)/N``, and the flight's pointing once, at
the window's end (the env docstrings' Rewards table). The per-step share is itself shaping, but not
potential-based: it also rewards a small envelope early in the window, which the score does not.
``reward_shaping: potential`` in a run's hyperparameters trains instead on

| step | shaped reward |
|---|---|
| one that does not end the episode | ``γ Φ(s′) − Φ(s)`` |
| the last (or a divergence) | the env's reward there ``− Φ(s)`` |

with the potential ``Φ = −ρ(envelope)`` (zero at an episode's start and end) and ``γ`` the
algorithm's discount. The shaping terms' discounted sum over an episode is ``γᵀ Φ(end) − Φ(start)
= 0``, so the discounted return of every policy is that of the env's last reward alone: the
pointing, its bonus, the last step's envelope share and the divergence penalty. The optimal
policies are those of the score's reward; what changes is the credit each step gets (the envelope's
improvement, seen at once, instead of a terminal reward discounted by ``γᴺ``).

Training's envs are shaped, the selection episodes' too (SB3 syncs the normalisation statistics
along two chains of the same wrappers): selection reads ``info["is_success"]`` (the shaped return
only breaks its ties), evaluation plays the env itself, and the logged episode returns
(``VecMonitor``, below this wrapper) stay the env's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn

#: The values of the ``reward_shaping`` hyperparameter (absent: the env's reward).
SHAPINGS = ("potential",)


def shaping_of(hyperparams: dict[str, Any]) -> str | None:
    """A run's reward shaping, or None for the env's reward; ``ValueError`` if unknown."""
    shaping = hyperparams.get("reward_shaping")
    if shaping is not None and shaping not in SHAPINGS:
        raise ValueError(f"reward_shaping must be one of {', '.join(SHAPINGS)}, got {shaping!r}")
    return shaping


class PotentialShapingVecEnv(VecEnvWrapper):
    """``venv``'s rewards replaced by the potential-shaped ones above, for discount ``gamma``.

    The potential is read back from the reward: on a step that does not end the episode the env
    pays exactly ``−ρ(envelope)/N``, so ``Φ = N × reward`` there.
    """

    def __init__(self, venv: VecEnv, gamma: float) -> None:
        super().__init__(venv)
        self.window_steps = venv.get_attr("episode_spec", [0])[0].n_steps
        self.gamma = gamma
        self._potential = np.zeros(venv.num_envs)  # Φ of each env's current state

    def reset(self) -> np.ndarray:
        self._potential[:] = 0.0
        return self.venv.reset()

    def step_wait(self) -> VecEnvStepReturn:
        observation, rewards, dones, infos = self.venv.step_wait()
        potential = np.where(dones, 0.0, self.window_steps * rewards.astype(np.float64))
        shaped = np.where(dones, rewards, 0.0) + self.gamma * potential - self._potential
        self._potential = potential  # after a done: the new episode's start, zero
        return observation, shaped.astype(np.float32), dones, infos
