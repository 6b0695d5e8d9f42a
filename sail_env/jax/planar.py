"""The planar tasks as pure JAX functions: gymnax's ``Environment`` over an explicit state pytree.

The task's matrices and tables come from the same NumPy/SciPy code the Numba core uses (the
:class:`~sail_env.core.spec.EpisodeSpec` built from the same keywords), handed over once as the
arrays of :class:`EnvParams`; this module holds only the episode logic: the clip and scale of the
action, the exact step, the divergence rule, the envelope, the reward, the termination, the
observation, and the coast and scoring at cut-off. Every function works on one environment;
``jax.vmap`` batches them (over states, and over params for per-environment tasks).

Covered today: the tasks without noise, light delay or parameter spread (``LightSail-v0``,
``LightSailDeepDish-v0`` and any planar keywords that add none of those); :func:`make` refuses the
others with a ``ValueError`` naming what is missing.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct
from gymnax.environments import environment, spaces

from sail_env.core.episode import OBSERVATION_LIMIT
from sail_env.core.reward import DIVERGENCE_PENALTY, SUCCESS_BONUS, succeeded
from sail_env.core.spec import EpisodeSpec
from sail_env.jax.arith import divide, log_ratio, ordered_dot


@struct.dataclass
class EnvState(environment.EnvState):
    """One episode (SI units). ``time`` counts the control steps taken (gymnax's field)."""

    x: jax.Array  # (n,) the true state
    last_command: jax.Array  # (m,) the beam input sent at the last step, held over the coast
    reward: jax.Array  # the last step's reward
    envelope: jax.Array  # the last step's envelope: largest |V⊥|/Vz with the input held [rad]
    terminated: jax.Array  # the last step ended the episode
    diverged: jax.Array  # the sail left the beam (in the window or the coast)
    pointing: jax.Array  # the flight direction at cut-off [rad]: NaN before the end, inf after a divergence


@struct.dataclass
class EnvParams:
    """A task's arrays, built by the NumPy/SciPy physics (:func:`params_of`); ``vmap`` over a
    batch of them gives each environment its own task. (gymnax's ``EnvParams`` is not the base: its
    field with a default would have to come first.)"""

    step_matrix: jax.Array  # (n, n + m): the exact control step [Φ Γ]
    envelope: jax.Array  # (n + m, S): the look-ahead table of the lateral speed, transposed
    limits: jax.Array  # (G,): the divergence groups' limits
    action_scale: jax.Array  # (m,): the beam input at action +1
    state_scale: jax.Array  # (n,): divides the state in the observation
    start_half_widths: jax.Array  # (n,): the uniform launch box
    launch_phi: jax.Array  # (n, n): the propagator from launch to the start of control (beam off)
    coast_phi: jax.Array  # (n, n): one coast piece's propagator
    coast_gamma: jax.Array  # (n, m): one coast piece's input matrix
    speed_at_cutoff: jax.Array  # axial speed at cut-off [m/s]
    max_steps_in_episode: int = struct.field(pytree_node=False, default=200)
    #: Pieces of the coast to cut-off (divergence is checked after each): static, so that the coast
    #: unrolls (one matrix product for a stable sail) instead of a loop of data-dependent length.
    coast_pieces: int = struct.field(pytree_node=False, default=1)


def params_of(spec: EpisodeSpec, dtype: jnp.dtype = jnp.float64) -> EnvParams:
    """The :class:`EnvParams` of a planar task's spec (its nominal model: no spread), its arrays
    (and so the episode's arithmetic) in ``dtype``: float64 is the Numba core's; float32 is faster
    on accelerators, its error measured in ``tests/jax/test_planar_jax.py`` and docs/performance.md."""
    plant, dist = spec.plant, spec.randomisation
    missing = [name for name, on in (("push_noise", dist.push_noise), ("sensor_noise_std", dist.any_sensor_noise),
                                     ("cutoff_jitter_s", dist.cutoff_jitter_s), ("light_delay", spec.light_delay),
                                     ("parameter_spread", dist.parameter_spread), ("random disturbances", dist.sources))
               if on]
    if missing or plant.biased:
        raise ValueError(f"the JAX backend does not carry {', '.join(missing) or 'a constant drive'} yet: "
                         f"only planar tasks without noise, delay or spread (LightSail-v0, LightSailDeepDish-v0)")
    p = plant.params(np.ones((1, plant.n_factors)))
    config = spec.config
    cutoff = config.beam_cutoff_s
    remaining = max(cutoff - (config.control_start_s + spec.n_steps * spec.dt), 0.0)
    pieces = int(plant.coast_pieces(p, np.array([remaining]))[0])
    coast_phi, coast_gamma = plant.nominal.discretize(remaining / pieces)
    pre_control = config.control_start_s
    launch_phi = plant.nominal.discretize(pre_control)[0] if pre_control > 0 else np.eye(plant.n_states)
    def array(values: np.ndarray) -> jax.Array:
        return jnp.asarray(values, dtype=dtype)

    return EnvParams(
        step_matrix=array(p.step[0]), envelope=array(p.envelope[0].T), limits=array(p.limits[0]),
        action_scale=array(spec.action_scale), state_scale=array(spec.state_scale),
        start_half_widths=array(spec.start_half_widths), launch_phi=array(launch_phi), coast_phi=array(coast_phi),
        coast_gamma=array(coast_gamma), speed_at_cutoff=array(plant.speed(p, np.array([cutoff]))[0]),
        max_steps_in_episode=spec.n_steps, coast_pieces=pieces)


class PlanarSailEnv(environment.Environment[EnvState, EnvParams]):
    """A planar light-sail task in gymnax's API (``reset(key, params)``, ``step(key, state,
    action, params)`` with autoreset, the spaces); :func:`sail_env.jax.make` builds one.

    The episode is the Numba core's (:mod:`sail_env.core.kernels`, :mod:`sail_env.core.episode`):
    fed the same launch states and actions, both give the same observations to the bit on a CPU
    (under the XLA flag of :mod:`sail_env.jax.arith`), rewards within 1e-12 and terminal pointing
    within 1e-9 (``tests/jax/test_planar_jax.py``). At an episode's end ``info`` carries the Gym
    envs' scores: ``is_success``, ``terminal_pointing_rad`` (NaN before the end, inf after a
    divergence) and ``diverged``.
    """

    def __init__(self, spec: EpisodeSpec, env_id: str = "LightSail", dtype: jnp.dtype = jnp.float64) -> None:
        super().__init__()
        plant = spec.plant
        self.spec = spec  # what controllers design on, as the Gym envs' ``episode_spec``
        self._id = env_id
        self.n_states, self.n_inputs = plant.n_states, plant.n_inputs
        self.observation_size = spec.observation_size
        self.divergence_groups = plant.divergence_groups
        self.velocity_rows = plant.velocity_rows
        self._params = params_of(spec, dtype)

    @property
    def name(self) -> str:
        return self._id

    @property
    def default_params(self) -> EnvParams:
        return self._params

    @property
    def num_actions(self) -> int:
        return self.n_inputs

    def action_space(self, params: EnvParams | None = None) -> spaces.Box:
        return spaces.Box(-1.0, 1.0, (self.n_inputs,), jnp.float32)

    def observation_space(self, params: EnvParams | None = None) -> spaces.Box:
        return spaces.Box(-OBSERVATION_LIMIT, OBSERVATION_LIMIT, (self.observation_size,), jnp.float32)

    # ------------------------------------------------------------------ reset
    def reset_env(self, key: jax.Array, params: EnvParams) -> tuple[jax.Array, EnvState]:
        """A launch state drawn uniformly in ``params.start_half_widths`` (:meth:`reset_from`)."""
        half = params.start_half_widths
        u = jax.random.uniform(key, half.shape, dtype=half.dtype)
        return self.reset_from(-half + (half - -half) * u, params)

    def reset_from(self, launch: jax.Array, params: EnvParams) -> tuple[jax.Array, EnvState]:
        """An episode from a given launch state (n,): the same-draws entry the cross-backend tests
        feed both backends through (the Numba core's ``initial_states``)."""
        x = ordered_dot(params.launch_phi, launch)
        zero = jnp.zeros((), dtype=x.dtype)
        state = EnvState(time=jnp.zeros((), jnp.int32), x=x, last_command=jnp.zeros(self.n_inputs, x.dtype),
                         reward=zero, envelope=zero, terminated=jnp.array(False), diverged=jnp.array(False),
                         pointing=jnp.full((), jnp.nan, x.dtype))
        return self.observe_state(state, params), state

    # ------------------------------------------------------------------ step
    def step_env(self, key: jax.Array, state: EnvState, action: jax.Array,
                 params: EnvParams) -> tuple[jax.Array, EnvState, jax.Array, jax.Array, dict[str, Any]]:
        """One control step (the compiled kernel's order), then at the window's end the coast and
        the score. A NaN action makes the state NaN and the episode diverge (JAX cannot raise)."""
        del key  # no noise on these tasks
        command = jnp.clip(jnp.asarray(action, params.action_scale.dtype), -1.0, 1.0) * params.action_scale
        x = ordered_dot(params.step_matrix, jnp.concatenate([state.x, command]))
        peak = self._peak_speed(params.envelope, jnp.concatenate([x, command]))
        envelope = divide(peak, params.speed_at_cutoff)
        window = params.max_steps_in_episode
        time = state.time + 1
        diverged = self._diverged(x, params)
        terminated = diverged | (time >= window)
        reward = jnp.where(diverged, DIVERGENCE_PENALTY, divide(-log_ratio(envelope), window))
        state = state.replace(time=time, x=x, last_command=command, reward=reward, envelope=envelope,
                              terminated=terminated, diverged=diverged)
        state = self._score(state, params)
        return self.observe_state(state, params), state, state.reward, terminated, self.scores(state)

    @staticmethod
    def scores(state: EnvState) -> dict[str, jax.Array]:
        """What the Gym envs report at an episode's end (meaningful once ``terminated``)."""
        return {"is_success": succeeded(state.pointing), "terminal_pointing_rad": state.pointing,
                "diverged": state.diverged, "envelope_rad": state.envelope}

    def is_truncated(self, state: EnvState, params: EnvParams) -> jax.Array:
        """Never: the window's end terminates the episode (it is scored at cut-off)."""
        return jnp.array(False)

    def _diverged(self, x: jax.Array, params: EnvParams) -> jax.Array:
        """The plant's divergence rule (:attr:`~sail_env.core.plant.Plant.divergence_groups`); NaN diverges."""
        out = jnp.array(False)
        for column, rows in enumerate(self.divergence_groups):
            size = jnp.abs(x[rows[0]]) if len(rows) == 1 else jnp.hypot(x[rows[0]], x[rows[1]])
            out = out | ~(size <= params.limits[column])
        return out

    def _peak_speed(self, envelope: jax.Array, z: jax.Array) -> jax.Array:
        """Largest lateral speed over the look-ahead samples with the input held (the kernels'
        ``_peak_speed``: each sample's sum over the columns in order)."""
        width = z.shape[0]
        squares = None
        for r in range(len(self.velocity_rows)):
            speeds = ordered_dot(envelope[r * width:(r + 1) * width].T, z)
            squares = speeds * speeds if squares is None else squares + speeds * speeds
        if len(self.velocity_rows) == 1:
            return jnp.max(jnp.abs(speeds))
        return jnp.sqrt(jnp.max(squares))

    def _score(self, state: EnvState, params: EnvParams) -> EnvState:
        """Coast a finished window to cut-off with the last command held and score it (the
        computation runs every step and is selected, as ``vmap`` would run both branches anyway)."""
        final, coast_lost = state.x, jnp.array(False)
        drive = params.coast_gamma @ state.last_command
        for _ in range(params.coast_pieces):
            final = jnp.where(coast_lost, final, params.coast_phi @ final + drive)
            coast_lost = coast_lost | self._diverged(final, params)
        velocity = final[jnp.array(self.velocity_rows)]
        pointing = divide(jnp.sqrt(jnp.sum(velocity * velocity)), params.speed_at_cutoff)
        scored = state.terminated & ~state.diverged
        bonus = jnp.where(succeeded(pointing), SUCCESS_BONUS, 0.0)
        reward = jnp.where(scored, state.reward + (-log_ratio(pointing) + bonus), state.reward)
        diverged = state.diverged | (scored & coast_lost)
        reward = jnp.where(diverged, DIVERGENCE_PENALTY, reward)
        pointing = jnp.where(diverged, jnp.inf, jnp.where(scored, pointing, jnp.nan))
        return state.replace(reward=reward, diverged=diverged, pointing=pointing)

    # ------------------------------------------------------------------ observation
    def observe_state(self, state: EnvState, params: EnvParams) -> jax.Array:
        """The state over its scales (clipped to the observation's limit), then the progress
        through the window, as float32 (the kernels' ``_observe``)."""
        scaled = jnp.clip(divide(state.x, params.state_scale), -OBSERVATION_LIMIT, OBSERVATION_LIMIT)
        progress = divide(2.0 * state.time.astype(params.state_scale.dtype), params.max_steps_in_episode) - 1.0
        return jnp.concatenate([scaled, progress[None]]).astype(jnp.float32)

    def get_obs(self, state: EnvState, params: EnvParams | None = None, key: jax.Array | None = None) -> jax.Array:
        return self.observe_state(state, self.default_params if params is None else params)
