"""LQG with light-delay compensation: the classical reference for LightSailRealistic-v0.

* A steady-state Kalman filter on the exact discretisation estimates the state the
  (delayed, noisy) observation shows. Process noise: the beam jitter through the
  input matrix, the push noise at the state scale, and a floor for the ±10 % model
  mismatch.
* The estimate is predicted forward, through the commands the agent already sent
  (still in flight or already acting), to the step its new command will reach the sail.
* The LQR gain of :mod:`agents.lqr` acts on that prediction.

Only the nominal model, the noise levels and the light delay (known from ranging)
are used; the episode's randomised parameters are not.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import scipy.linalg

from agents.lqr import lqr_gain

#: Process-noise floor per step, relative to the observation scales (model mismatch).
MODEL_MISMATCH = 3e-3


class LQGAgent:
    """Kalman filter + delay predictor + LQR, with memory of the commands it sent."""

    name = "lqg"

    def __init__(self, env: gym.Env, input_weight: float = 10.0) -> None:
        self.env = env.unwrapped
        model, dt = self.env.nominal_model, self.env.config.control_step_s
        self.phi, self.gamma = model.discretize(dt)
        scale = self.env.state_scale
        self.gain = lqr_gain(model, dt, scale, self.env.action_scale, input_weight)
        dist = self.env.disturbances
        a_push, b_push = model.push_sensitivity
        push_kick = a_push @ scale * dt
        process = (dist.beam_jitter_m**2 * np.outer(self.gamma[:, 0], self.gamma[:, 0])
                   + dist.push_noise**2 * np.outer(push_kick, push_kick)
                   + np.diag((MODEL_MISMATCH * scale) ** 2))
        sensor = np.diag(np.maximum(np.asarray(dist.sensor_noise_std), 1e-6 * scale) ** 2)
        covariance = scipy.linalg.solve_discrete_are(self.phi.T, np.eye(4), process, sensor)
        self.kalman_gain = covariance @ np.linalg.inv(covariance + sensor)
        self.reset()

    def reset(self) -> None:
        self.step = 0
        self.sent: list[np.ndarray] = []
        self.estimate: np.ndarray | None = None
        self.estimate_step = 0

    def _applied(self, step: int) -> np.ndarray:
        """The input acting during ``step``, as the env's delay rule says."""
        index = step - self.env.delay_steps(step)
        if index < 0 or not self.sent:
            return np.zeros(2)
        return self.sent[min(index, len(self.sent) - 1)]

    def act(self, observation: np.ndarray) -> np.ndarray:
        measured = self.env.observation_to_state(observation)
        shown = self.step - self.env.delay_steps(self.step)
        if self.estimate is None:
            self.estimate, self.estimate_step = measured, shown
        while self.estimate_step < shown:
            self.estimate = self.phi @ self.estimate + self.gamma @ self._applied(self.estimate_step)
            self.estimate_step += 1
        self.estimate = self.estimate + self.kalman_gain @ (measured - self.estimate)
        # Predict to the step at which the new command starts to act.
        prediction, step = self.estimate, self.estimate_step
        arrival = self.step + self.env.delay_steps(self.step)
        while step < arrival:
            prediction = self.phi @ prediction + self.gamma @ self._applied(step)
            step += 1
        command = np.clip(-self.gain @ prediction, -self.env.action_scale, self.env.action_scale)
        self.sent.append(command)
        self.step += 1
        return self.env.input_to_action(command)
