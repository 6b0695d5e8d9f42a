"""Discrete-time LQR on the exact (zero-order-hold) discretisation of the planar model.

At the seed's design point (``Lc = R``) the tilt is uncontrollable and neutral, so the
Riccati equation for the full state has no stabilising solution. The gain is designed
on the controllable subspace instead (Kalman decomposition: ``x_c = Tᵀ x`` with ``T`` an
orthonormal basis of ``range[B, AB, A²B, A³B]``), which is the full state wherever the
configuration allows. The uncontrollable part then acts on the controlled one as a
slowly varying load; the closed loop settles on the equilibrium it sets, with ``V⊥ = 0``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from sail_env.core.spec import EpisodeSpec
from sail_env.physics.planar import PlanarModel

#: Weights on (X, Vx, θ, ω), relative to the observation scales: speed matters most,
#: because the flight direction is ``V⊥/Vz``.
STATE_WEIGHTS = (1.0, 10.0, 1.0, 1.0)


def lqr_gain(model: PlanarModel, dt: float, state_scale: np.ndarray, input_scale: np.ndarray,
             input_weight: float = 1.0) -> np.ndarray:
    """Gain ``K`` (SI) for ``u = −K x`` minimising ``Σ xᵀQx + uᵀRu`` on the exact discretisation.

    ``Q`` and ``R`` are diagonal in units of ``state_scale`` and ``input_scale``.
    """
    phi, gamma = model.discretize(dt)
    basis = model.controllable_basis
    if basis.shape[1] == 0:
        raise ValueError("the beam inputs cannot influence this sail: nothing to control")
    q = np.diag(np.asarray(STATE_WEIGHTS) / state_scale**2)
    r = input_weight * np.diag(1.0 / input_scale**2)
    phi_c, gamma_c, q_c = basis.T @ phi @ basis, basis.T @ gamma, basis.T @ q @ basis
    try:
        p = scipy.linalg.solve_discrete_are(phi_c, gamma_c, q_c, r)
    except (np.linalg.LinAlgError, ValueError) as err:
        raise ValueError(f"no stabilising LQR gain for this configuration: {err}") from err
    k_c = np.linalg.solve(r + gamma_c.T @ p @ gamma_c, gamma_c.T @ p @ phi_c)
    return k_c @ basis.T


class LQRAgent:
    """Full-state feedback from the observation, saturated to the action limits.

    Designed on the task's nominal model (``env.unwrapped.episode_spec``); acts on one
    observation (D,) or a batch (N, D).
    """

    name = "lqr"

    def __init__(self, spec: EpisodeSpec, input_weight: float = 1.0) -> None:
        self.spec = spec
        self.gain = lqr_gain(spec.nominal, spec.dt, spec.state_scale, spec.action_scale, input_weight)

    def act(self, observation: np.ndarray) -> np.ndarray:
        return self.spec.input_to_action(-self.spec.observation_to_state(observation) @ self.gain.T)

    def reset(self) -> None:
        """Memoryless."""
