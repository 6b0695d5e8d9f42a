"""LQG with light-delay compensation: the classical reference for LightSailRealistic-v0.

* A steady-state Kalman filter on the exact discretisation estimates the state the
  (delayed, noisy) observation shows. Process noise: the beam jitter through the
  input matrix, the push noise at the state scale, and a floor for the ±10 % model
  mismatch.
* The estimate is predicted forward, through the commands the agent already sent
  (still in flight or already acting), to the step its new command will reach the sail,
  with the episode core's delay rule (``EpisodeSpec.delay_steps`` and
  ``sail_env.core.delay.arrived_command``, the compiled step's own).
* The LQR gain of :mod:`agents.lqr`, with the same weights, acts on that prediction. (An input
  weight of 10, once chosen on the planar tasks, was no better there and fails the 3D sail with
  absorption, whose tilt is slowly unstable: 12 % against 100 % success.)
* A known constant term of the model (a payload off the sail axis, docs/physics.md §15) drives
  the prediction too; the gain does not cancel it (the loop settles where the sail is at rest).

Only the nominal model, the noise levels and the nominal light delay are used; the
episode's randomised parameters are not.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from agents.lqr import INPUT_WEIGHT, lqr_gain, state_weights
from sail_env.core.delay import arrived_command
from sail_env.core.spec import EpisodeSpec
from sail_env.physics.linear import zoh_discretize

#: Process-noise floor per step, relative to the observation scales (model mismatch).
MODEL_MISMATCH = 3e-3


class LQGAgent:
    """Kalman filter + delay predictor + LQR, with memory of the commands it sent.

    Acts on one observation (D,) or a batch (N, D) of episodes started together.
    """

    name = "lqg"

    def __init__(self, spec: EpisodeSpec, input_weight: float = INPUT_WEIGHT) -> None:
        self.spec = spec
        model, dt, scale = spec.nominal, spec.dt, spec.state_scale
        self.phi, self.gamma = model.discretize(dt)
        # The constant term c as an input held at 1: its exact step drive ∫Φ c.
        self.drift = zoh_discretize(model.A, spec.plant.constant_term[:, None], dt)[1][:, 0]
        self.gain = lqr_gain(model, dt, scale, spec.action_scale, input_weight, state_weights(spec))
        dist = spec.disturbances
        a_push, _ = model.push_sensitivity
        push_kick = a_push @ scale * dt
        jitter = self.gamma[:, list(spec.plant.jitter_inputs)]
        process = (dist.beam_jitter_m**2 * jitter @ jitter.T
                   + dist.push_noise**2 * np.outer(push_kick, push_kick)
                   + np.diag((MODEL_MISMATCH * scale) ** 2))
        sensor = np.diag(np.maximum(spec.sensor_noise_std, 1e-6 * scale) ** 2)
        covariance = scipy.linalg.solve_discrete_are(self.phi.T, np.eye(len(scale)), process, sensor)
        self.kalman_gain = covariance @ np.linalg.inv(covariance + sensor)
        self.reset()

    def reset(self) -> None:
        self.step = 0
        self.sent: list[np.ndarray] = []
        self.estimate: np.ndarray | None = None
        self.estimate_step = 0

    def _applied(self, step: int, state: np.ndarray) -> np.ndarray:
        """The input acting during ``step``, by the core's delay rule (:func:`arrived_command`)."""
        index = arrived_command(step, int(self.spec.delay_steps(step)), len(self.sent) - 1)
        if index < 0:
            return np.zeros((*state.shape[:-1], self.gamma.shape[1]))
        return self.sent[index]

    def _predict(self, state: np.ndarray, step: int) -> np.ndarray:
        return state @ self.phi.T + self._applied(step, state) @ self.gamma.T + self.drift

    def act(self, observation: np.ndarray) -> np.ndarray:
        measured = self.spec.observation_to_state(observation)
        shown = self.step - int(self.spec.delay_steps(self.step))
        if self.estimate is None:
            self.estimate, self.estimate_step = measured, shown
        while self.estimate_step < shown:
            self.estimate = self._predict(self.estimate, self.estimate_step)
            self.estimate_step += 1
        self.estimate = self.estimate + (measured - self.estimate) @ self.kalman_gain.T
        # Predict to the step at which the new command starts to act.
        prediction, step = self.estimate, self.estimate_step
        arrival = self.step + int(self.spec.delay_steps(self.step))
        while step < arrival:
            prediction = self._predict(prediction, step)
            step += 1
        scale = self.spec.action_scale
        command = np.clip(-prediction @ self.gain.T, -scale, scale)
        self.sent.append(command)
        self.step += 1
        return self.spec.input_to_action(command)
