"""Ceiling agents: controllers no ground station could field, which bound what one can achieve.

Both read the episode's truth through one privileged accessor, :func:`episode_truth` (the true
state now and the parameter draw's model), which is the only place that knows how the env's
episode state stores them: adapt it, and only it, when that structure changes.

* ``lqr-oracle`` (:class:`OracleLQRAgent`): the LQR of :mod:`agents.lqr` designed at every reset on
  the episode's own drawn model ``(A, B, c)``, acting on the **true state now** (no sensor noise, no
  observation delay). Its command still needs the light's time to reach the sail — that is physics,
  not information — so it predicts the true state to the command's arrival with the true model,
  the true delay of the draw and the commands in flight. What is left against it is only what no
  controller in the window can remove: the noise that acts while a command travels, the
  disturbances over the coast, the cut-off's phase.
* ``lqg-oracle`` (:class:`OracleLQGAgent`): :class:`agents.lqg.LQGAgent`'s loop (same filter, same
  delayed noisy observation, same weights) designed at every reset on the episode's drawn model
  and its true light delay: what the parameter spread costs the nominal LQG.

They are bounds for the benchmark's tables, not baselines: an agent that beats ``lqg`` but not
``lqg-oracle`` has found what a known model is worth; one within the LQR oracle's reach has little
left to gain. Both need the env (:meth:`attach`) before their first episode; the evaluation
(:mod:`agents.evaluation`) attaches them to the env it steps.
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np

from agents.lqg import MODEL_MISMATCH, LQGAgent, LQGDesign, lqg_design
from agents.lqr import INPUT_WEIGHT
from sail_env.core.spec import EpisodeSpec


@dataclasses.dataclass(frozen=True)
class EpisodeTruth:
    """What only the simulator knows, per environment (leading axis N).

    Attributes:
        state: The true state now (N, n) [SI], before this step's command.
        a: The drawn model's system matrix (N, n, n) in the control window.
        b: Its input matrix (N, n, m) (the constant term's column removed).
        constant: Its constant term ``c`` (N, n) (zero without one).
        acceleration: The draw's axial acceleration (N,) [m/s²]: it sets the light delay.
    """

    state: np.ndarray
    a: np.ndarray
    b: np.ndarray
    constant: np.ndarray
    acceleration: np.ndarray


def episode_truth(env: gym.Env | gym.vector.VectorEnv) -> EpisodeTruth:
    """PRIVILEGED: the true state and each episode's drawn window model, read from the env's
    episode state (``env.unwrapped.state``, an :class:`~sail_env.core.state.EpisodeState`: ``x`` and
    ``params``). The one function to adapt when that structure changes; nothing else in
    :mod:`agents` reads it."""
    state = env.unwrapped.state
    p, n_envs, m = state.params, state.x.shape[0], env.unwrapped.episode_spec.plant.n_inputs
    a = np.broadcast_to(p.a, (n_envs, *p.a.shape[1:]))
    b = np.broadcast_to(p.b, (n_envs, *p.b.shape[1:]))
    constant = b[:, :, m] if b.shape[2] > m else np.zeros(a.shape[:2])
    acceleration = np.broadcast_to(p.acceleration, (n_envs,))
    return EpisodeTruth(state.x.copy(), a.copy(), b[:, :, :m].copy(), constant.copy(), acceleration.copy())


class _OracleMixin:
    """Holds the env, redesigns on every reset, and uses each draw's own light delay."""

    spec: EpisodeSpec
    env: gym.Env | gym.vector.VectorEnv | None = None
    acceleration: np.ndarray | None = None

    def attach(self, env: gym.Env | gym.vector.VectorEnv) -> None:
        """Use ``env``'s truth (call before its first reset's :meth:`reset`): a lightsail-gym env, or its
        batched vector env. SB3's and Gymnasium's one-env-at-a-time vector envs (``"sync"``, ``"async"``)
        hide their envs' episode state: refused."""
        spec = getattr(env.unwrapped, "episode_spec", None)
        if spec is None or not hasattr(env.unwrapped, "state"):
            raise ValueError(f"attach: {self.name} reads the episode state of a lightsail-gym env or of its batched "
                             "vector env (gym.make_vec(..., vectorization_mode='vector_entry_point')), "
                             f"not of {type(env.unwrapped).__name__}")
        plant = spec.plant
        if (plant.n_states, plant.n_inputs) != (self.spec.plant.n_states, self.spec.plant.n_inputs):
            raise ValueError(f"attach: the env's plant has {plant.n_states} states and {plant.n_inputs} inputs, "
                             f"the agent's {self.spec.plant.n_states} and {self.spec.plant.n_inputs}")
        self.env, self.acceleration = env, None  # designed on this env's draw at the next reset

    def act(self, observation: np.ndarray) -> np.ndarray:
        """As the LQG's, once designed on the attached env's episode: unattached, ``lqg-oracle`` played
        the nominal LQG under the oracle's name."""
        if self.env is None:
            raise RuntimeError(f"{self.name} reads the simulator's truth: attach(env) before acting")
        if self.acceleration is None:
            raise RuntimeError(f"{self.name}: reset() after attach(env), before acting (it designs on the "
                               "episode's draw)")
        return super().act(observation)

    def _truth(self) -> EpisodeTruth:
        if self.env is None:
            raise RuntimeError(f"{self.name} reads the simulator's truth: attach(env) before acting")
        return episode_truth(self.env)

    def _redesign(self, input_weight: float, model_mismatch: float) -> None:
        truth = self._truth()
        self.acceleration = truth.acceleration
        self.design = LQGDesign.stack([lqg_design(self.spec, a, b, c, input_weight, model_mismatch)
                                       for a, b, c in zip(truth.a, truth.b, truth.constant)])

    def delay(self, step: np.ndarray) -> np.ndarray:
        """The draw's own one-way delay [steps] (its acceleration sets its distance)."""
        accel = self.spec.plant.acceleration_m_s2 if self.acceleration is None else self.acceleration
        return np.asarray(self.spec.delay_steps(step, accel), dtype=np.int64)


class OracleLQGAgent(_OracleMixin, LQGAgent):
    """:class:`LQGAgent` designed on each episode's drawn model and its true delay (a bound)."""

    name = "lqg-oracle"

    def reset(self) -> None:
        super().reset()
        if self.env is not None:
            self._redesign(self.input_weight, self.model_mismatch)


class OracleLQRAgent(_OracleMixin, LQGAgent):
    """The LQR on each episode's drawn model, acting on the true state now predicted to its
    command's arrival (a bound; the module docstring)."""

    name = "lqr-oracle"

    def __init__(self, spec: EpisodeSpec, input_weight: float = INPUT_WEIGHT) -> None:
        super().__init__(spec, input_weight, MODEL_MISMATCH)

    def reset(self) -> None:
        super().reset()
        if self.env is not None:
            self._redesign(self.input_weight, self.model_mismatch)
            # The true state is measured exactly: the "filter" takes it as it is.
            n = self.spec.plant.n_states
            self.design = dataclasses.replace(self.design, kalman_gain=np.broadcast_to(np.eye(n), self.design.phi.shape))

    def measure(self, observation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The true state now, shown at the current step (the observation is ignored)."""
        state = self._truth().state
        return state, self.now(len(state))


def attach(agent: object, env: gym.Env | gym.vector.VectorEnv) -> None:
    """Give ``agent`` the env it will act in, if it reads the simulator's truth (a no-op otherwise)."""
    if hasattr(agent, "attach"):
        agent.attach(env)
