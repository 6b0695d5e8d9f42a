"""Discrete-time LQR on the exact (zero-order-hold) discretisation of a task's nominal linear model
(the planar one or the 3D linearisation: the dimensions come from the task's spec).

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

from agents.base import check_observation
from sail_env.core.spec import EpisodeSpec
from sail_env.physics.linear import LinearModel

#: Weights on (X, Vx, θ, ω), relative to the observation scales: speed matters most,
#: because the flight direction is ``V⊥/Vz``.
STATE_WEIGHTS = (1.0, 10.0, 1.0, 1.0)
#: The same weights by the unit of a state component (any model's).
WEIGHT_OF_UNIT = {"m": 1.0, "m/s": 10.0, "rad": 1.0, "rad/s": 1.0}
#: Weight on each input, relative to its action scale: LQR's and LQG's default.
INPUT_WEIGHT = 1.0


def state_weights(spec: EpisodeSpec) -> np.ndarray:
    """:data:`STATE_WEIGHTS` for the states of ``spec``'s plant (by their units)."""
    return np.array([WEIGHT_OF_UNIT[unit] for unit in spec.plant.state_units])


def lqr_gain(model: LinearModel, dt: float, state_scale: np.ndarray, input_scale: np.ndarray,
             input_weight: float = INPUT_WEIGHT, weights: np.ndarray | None = None) -> np.ndarray:
    """Gain ``K`` (SI) for ``u = −K x`` minimising ``Σ xᵀQx + uᵀRu`` on the exact discretisation.

    ``Q`` and ``R`` are diagonal in units of ``state_scale`` and ``input_scale``; ``weights``
    are the state weights (default :data:`STATE_WEIGHTS`, the planar model's).
    """
    phi, gamma = model.discretize(dt)
    basis = model.controllable_basis
    if basis.shape[1] == 0:
        raise ValueError("the beam inputs cannot influence this sail: nothing to control")
    q = np.diag(np.asarray(STATE_WEIGHTS if weights is None else weights) / state_scale**2)
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

    def __init__(self, spec: EpisodeSpec, input_weight: float = INPUT_WEIGHT) -> None:
        self.spec = spec
        self.gain = lqr_gain(spec.nominal, spec.dt, spec.state_scale, spec.action_scale, input_weight,
                             state_weights(spec))

    def act(self, observation: np.ndarray) -> np.ndarray:
        check_observation(self.spec, observation, self.name)
        return self.spec.input_to_action(-self.spec.observation_to_state(observation) @ self.gain.T)

    def reset(self, which: np.ndarray | None = None) -> None:
        """Memoryless: nothing to forget, for any episode."""
