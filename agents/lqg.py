"""LQG with light-delay compensation: the classical reference for LightSailRealistic-v0.

* A steady-state Kalman filter on the exact discretisation estimates the state the
  (delayed, noisy) observation shows. Process noise: every beam offset (the landing
  and the ground's pointing jitter) through the input matrix and the dust's kicks, as the spec
  sizes them (``EpisodeSpec.window_step_noise``), the push noise at the state scale, and a floor
  for the ±10 % model mismatch.
* The estimate is predicted forward, through the commands the agent already sent
  (still in flight or already acting), to the step its new command will reach the sail,
  with the episode core's delay rule (``EpisodeSpec.delay_steps``).
* The LQR gain of :mod:`agents.lqr`, with the same weights, acts on that prediction. (An input
  weight of 10, once chosen on the planar tasks, was no better there and fails the 3D sail with
  absorption, whose tilt is slowly unstable: 12 % against 100 % success.)
* A known constant term of the model (a payload off the sail axis, docs/physics.md §15) drives
  the prediction too; the gain does not cancel it (the loop settles where the sail is at rest).
  An unknown constant beam offset can join the filter's state instead (``offset_walk``,
  :func:`with_offset_estimate`: the offset-free design of ``lqg-mm-offset``).

:func:`lqg_design` is the design on one model ``(A, B, c)``; :class:`LQGAgent` runs it on the
nominal model, the noise levels and the nominal light delay: the episode's randomised parameters
are not used. The ceiling agents of :mod:`agents.oracle` run the same loop on each episode's drawn
model.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg

from agents.base import check_observation
from agents.lqr import INPUT_WEIGHT, lqr_gain, state_weights
from sail_env.core.delay import arrived_commands
from sail_env.core.spec import EpisodeSpec
from sail_env.physics.linear import LinearModel, zoh_discretize

#: Process-noise floor per step, relative to the observation scales (model mismatch).
MODEL_MISMATCH = 3e-3


@dataclasses.dataclass(frozen=True)
class LQGDesign:
    """One LQG design (SI): the exact step ``x ← Φ x + Γ u + drift``, the LQR gain (``u = −K x``)
    and the steady-state Kalman gain (``x̂ ← x̂ + L (y − x̂)``). Each array may lead with a batch
    axis (one design per environment)."""

    phi: np.ndarray
    gamma: np.ndarray
    drift: np.ndarray
    gain: np.ndarray
    kalman_gain: np.ndarray

    @staticmethod
    def stack(designs: list[LQGDesign]) -> LQGDesign:
        """One batched design of per-environment designs (a leading axis on every array)."""
        return LQGDesign(*(np.stack([getattr(d, f.name) for d in designs]) for f in dataclasses.fields(LQGDesign)))


def lqg_design(spec: EpisodeSpec, a: np.ndarray, b: np.ndarray, constant: np.ndarray,
               input_weight: float = INPUT_WEIGHT, model_mismatch: float = MODEL_MISMATCH,
               offset_walk: float = 0.0) -> LQGDesign:
    """The LQG of the module docstring designed on the model ``ds/dt = A s + B u + c`` (SI).

    The process noise uses the task's noise levels and the nominal push sensitivity (it sizes the
    push noise's kick, not the model); ``model_mismatch`` is the per-step floor in state scales
    (:data:`MODEL_MISMATCH`; larger: a filter that trusts its model less). ``offset_walk`` > 0: the
    offset-free design of :func:`with_offset_estimate`.
    """
    if not (np.isfinite(model_mismatch) and model_mismatch > 0):
        raise ValueError(f"model_mismatch must be finite and > 0, got {model_mismatch!r}")
    model = LinearModel(np.array(a, dtype=float), np.array(b, dtype=float))
    dt, scale = spec.dt, spec.state_scale
    phi, gamma = model.discretize(dt)
    # The constant term c as an input held at 1: its exact step drive ∫Φ c.
    drift = zoh_discretize(model.A, np.asarray(constant, dtype=float)[:, None], dt)[1][:, 0]
    gain = lqr_gain(model, dt, scale, spec.action_scale, input_weight, state_weights(spec))
    dist = spec.randomisation
    a_push, _ = spec.nominal.push_sensitivity
    push_kick = a_push @ scale * dt
    process = (spec.window_step_noise(gamma)
               + dist.push_noise**2 * np.outer(push_kick, push_kick)
               + np.diag((model_mismatch * scale) ** 2))
    sensor = np.diag(np.maximum(spec.sensor_noise_std, 1e-6 * scale) ** 2)
    if offset_walk:
        return with_offset_estimate(spec, LQGDesign(phi, gamma, drift, gain, np.empty(0)), process, sensor,
                                    offset_walk)
    covariance = scipy.linalg.solve_discrete_are(phi.T, np.eye(len(scale)), process, sensor)
    return LQGDesign(phi, gamma, drift, gain, covariance @ np.linalg.inv(covariance + sensor))


def with_offset_estimate(spec: EpisodeSpec, design: LQGDesign, process: np.ndarray, sensor: np.ndarray,
                         walk: float) -> LQGDesign:
    """An offset-free LQG (a disturbance observer; e.g. Pannocchia & Rawlings 2003): a constant beam
    offset at the sail that the station does not know (a pointing bias) joins the filter's state,
    one per beam-offset input, as a random walk of ``walk`` × that input's largest command per step,
    and every command subtracts its estimate. The filter measures the state alone (``[I 0]``)."""
    if not (np.isfinite(walk) and walk > 0):
        raise ValueError(f"offset_walk must be finite and > 0, got {walk!r}")
    offsets = [i for i, name in enumerate(spec.plant.input_names) if "offset" in name]
    phi, gamma = design.phi, design.gamma
    n, k, m = len(phi), len(offsets), gamma.shape[1]
    phi_a = np.block([[phi, gamma[:, offsets]], [np.zeros((k, n)), np.eye(k)]])
    cancel = np.zeros((m, k))
    cancel[offsets, np.arange(k)] = 1.0
    process_a = scipy.linalg.block_diag(process, np.diag((walk * spec.action_scale[offsets]) ** 2))
    measure = np.hstack([np.eye(n), np.zeros((n, k))])
    covariance = scipy.linalg.solve_discrete_are(phi_a.T, measure.T, process_a, sensor)
    kalman_gain = covariance @ measure.T @ np.linalg.inv(measure @ covariance @ measure.T + sensor)
    return LQGDesign(phi_a, np.vstack([gamma, np.zeros((k, m))]), np.concatenate([design.drift, np.zeros(k)]),
                     np.hstack([design.gain, cancel]), kalman_gain)


def _apply(matrix: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """``matrix @ v`` for each row of ``vectors`` (N, ·): one shared matrix or one per row."""
    return vectors @ matrix.T if matrix.ndim == 2 else np.einsum("nij,nj->ni", matrix, vectors)


class LQGAgent:
    """Kalman filter + delay predictor + LQR, with memory of the commands it sent.

    Acts on one observation (D,) or a batch (N, D) of episodes started together.
    ``model_mismatch``: the filter's process-noise floor (:func:`lqg_design`).
    """

    name = "lqg"

    def __init__(self, spec: EpisodeSpec, input_weight: float = INPUT_WEIGHT,
                 model_mismatch: float = MODEL_MISMATCH, offset_walk: float = 0.0) -> None:
        self.spec = spec
        self.input_weight, self.model_mismatch = input_weight, model_mismatch
        self.design = lqg_design(spec, spec.nominal.A, spec.nominal.B, spec.plant.constant_term, input_weight,
                                 model_mismatch, offset_walk)
        self.reset()

    @property
    def gain(self) -> np.ndarray:
        return self.design.gain

    @property
    def kalman_gain(self) -> np.ndarray:
        return self.design.kalman_gain

    def reset(self, which: np.ndarray | None = None) -> None:
        """Start afresh: every episode, or only those where ``which`` (N,) is true (the episodes an
        autoresetting batch has just begun; the others keep their filter and commands)."""
        if which is None or getattr(self, "steps", None) is None:
            self.steps: np.ndarray | None = None  # commands each episode has sent (N,); None before the first
            self._sent: np.ndarray | None = None  # the commands sent, (capacity, N, m), by each episode's step
            self.estimate: np.ndarray | None = None
            self.estimate_step: np.ndarray | None = None
            return
        which = np.asarray(which, dtype=bool)
        self.steps[which] = 0  # their stored commands are overwritten before they are read again
        self._fresh |= which

    @property
    def last_command(self) -> np.ndarray:
        """The command (N, m) [SI] each episode sent last."""
        return self._sent[self.steps - 1, np.arange(len(self.steps))]

    def replace_last_command(self, command: np.ndarray) -> None:
        """Record ``command`` (N, m) as the one each episode sent last (a bank that acts for its members)."""
        self._sent[self.steps - 1, np.arange(len(self.steps))] = command

    def delay(self, step: np.ndarray) -> np.ndarray:
        """One-way delay [steps] at control steps ``step`` (N,): the nominal rule."""
        return np.asarray(self.spec.delay_steps(step), dtype=np.int64)

    def now(self, n: int) -> np.ndarray:
        """Each of the ``n`` episodes' control step (N,): the commands it has sent."""
        if self.steps is None:
            self.steps = np.zeros(n, dtype=np.int64)
            self._sent = np.zeros((64, n, self.design.gamma.shape[-1]))
            self._fresh = np.ones(n, dtype=bool)
        elif len(self.steps) != n:
            raise ValueError(f"observation batch must keep its size {len(self.steps)} until reset(), got {n}")
        return self.steps

    def measure(self, observation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The measured state (N, n) and the step it shows (N,)."""
        measured = self.spec.observation_to_state(observation)
        now = self.now(len(measured))
        return measured, now - self.delay(now)

    def _applied(self, step: np.ndarray) -> np.ndarray:
        """The input (N, m) acting during each environment's ``step`` (N,), by the core's delay rule."""
        index = np.empty(len(step), dtype=np.int64)
        arrived_commands(step, self.delay(step), self.steps - 1, index)
        applied = self._sent[np.maximum(index, 0), np.arange(len(step))]
        return np.where((index >= 0)[:, None], applied, 0.0)

    def _predict(self, state: np.ndarray, step: np.ndarray) -> np.ndarray:
        d = self.design
        return _apply(d.phi, state) + _apply(d.gamma, self._applied(step)) + d.drift

    def _advance(self, state: np.ndarray, step: np.ndarray, until: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predict each environment's ``state`` from ``step`` to ``until`` (N,)."""
        step = step.copy()
        while np.any(moving := step < until):
            state = np.where(moving[:, None], self._predict(state, step), state)
            step += moving
        return state, step

    def command(self, observations: np.ndarray) -> np.ndarray:
        """The beam input (N, m) [SI] for observations (N, D), remembered as sent; the filter's
        innovation (the measurement minus its prediction) is left in :attr:`innovation`."""
        check_observation(self.spec, observations, self.name)
        measured, shown = self.measure(observations)
        # The filter's state: the measured one, then any estimated offsets (zero at the start).
        start = np.pad(measured, ((0, 0), (0, self.design.phi.shape[-1] - measured.shape[1])))
        if self.estimate is None:
            self.estimate, self.estimate_step = start, shown
        elif self._fresh.any():  # episodes begun since the last command start from their measurement
            self.estimate = np.where(self._fresh[:, None], start, self.estimate)
            self.estimate_step = np.where(self._fresh, shown, self.estimate_step)
        self._fresh[:] = False
        self.estimate, self.estimate_step = self._advance(self.estimate, self.estimate_step, shown)
        self.innovation = measured - self.estimate[:, :measured.shape[1]]
        self.estimate = self.estimate + _apply(self.design.kalman_gain, self.innovation)
        # Predict to the step at which the new command starts to act.
        now = self.steps
        prediction, _ = self._advance(self.estimate, self.estimate_step, now + self.delay(now))
        scale = self.spec.action_scale
        command = np.clip(-_apply(self.design.gain, prediction), -scale, scale)
        if now.max() >= len(self._sent):  # a longer episode than stored so far: double the store
            self._sent = np.concatenate([self._sent, np.zeros_like(self._sent)])
        self._sent[now, np.arange(len(now))] = command
        self.steps = now + 1
        return command

    def act(self, observation: np.ndarray) -> np.ndarray:
        command = self.command(np.atleast_2d(observation))
        return self.spec.input_to_action(command[0] if np.ndim(observation) == 1 else command)
