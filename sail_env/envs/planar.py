"""LightSail-v0 and its planar siblings: keep a laser-driven light sail on its beam."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from sail_env.envs.disturbances import Disturbances
from sail_env.envs.rendering import SailRenderer
from sail_env.physics.config import PRESETS, SailConfig
from sail_env.physics.mission import one_way_light_delay_s
from sail_env.physics.noise import propagate_moments, sample_gaussian
from sail_env.physics.planar import STATE_NAMES, THETA, VX, X, PlanarModel, zoh_discretize
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD, EnvelopeEstimator, pointing_error

#: Half-widths of the default uniform start distribution, ``(X, Vx, θ, ω)`` in SI.
DEFAULT_START_HALF_WIDTHS = (5e-3, 0.1, 2e-3, 1e-5)
#: Observation scales: the state is divided by these (rates by the model's frequency too).
POSITION_SCALE_M = 1e-2
TILT_SCALE_RAD = 1e-3
#: The sail has left the small-angle regime the model is valid in.
MAX_TILT_RAD = 0.05
#: Reward: log10 of (pointing / tolerance) is clipped to this range.
LOG_RATIO_RANGE = (-2.0, 3.0)
SUCCESS_BONUS = 1.0
DIVERGENCE_PENALTY = -10.0
OBSERVATION_LIMIT = 1e3


class LightSailEnv(gym.Env[np.ndarray, np.ndarray]):
    """
    ## Description

    A gram-scale light sail is pushed by a laser to 0.2 c (Breakthrough Starshot). It
    must leave the beam flying within 10 nrad of its target line, or it misses Proxima b
    by more than the Earth-Moon distance. The sail is the seed paper's spherical dish
    with a payload on struts (Team 258, MCM Problem A, eqs 16-19, corrected as in
    ``sail_env.physics.planar``); in the plane it has four states, and a curved dish
    makes a restoring force but never damps: the passive sail never forgets a
    perturbation. The agent steers the beam during the early flight (the *control
    window*), the rest of the beam time to cut-off is propagated exactly with the last
    command held, and the episode is scored by the flight direction at cut-off.

    The oscillation period is ~0.09 s and the beam time 600 s; stepping through all of
    it would take 10⁵ steps, so an episode is the window (default 200 steps of 5 ms,
    about 11 periods) plus one exact propagation. Because V⊥ keeps oscillating after
    control, the only way to score well at an uncertain cut-off time is to damp it.

    ## Action Space

    ``Box(-1, 1, (2,), float32)``, scaled inside:

    | Num | Action | Physical range |
    |-----|--------|----------------|
    | 0 | beam lateral offset ``d`` at the sail | ± ``max_beam_offset_m`` (2 cm) |
    | 1 | beam tilt ``ψ`` | ± ``max_beam_tilt_rad`` (2 mrad) |

    Actions outside [-1, 1] are clipped; a NaN or infinite action raises ``ValueError``.
    In this planar model both act through the beam's landing point on the sail,
    ``d + Lc ψ`` (see ``sail_env.physics.planar``); the 3D model separates them.

    ## Observation Space

    ``Box(-1e3, 1e3, (5 + 2 n,), float32)`` (clipped to that range):

    | Num | Observation | Scale |
    |-----|-------------|-------|
    | 0 | lateral offset X of the CoM | / 1 cm |
    | 1 | lateral speed Vx | / (1 cm · ω₀) |
    | 2 | tilt θ of the sail axis | / 1 mrad |
    | 3 | tilt rate ω | / (1 mrad · ω₀) |
    | 4 | progress through the control window | -1 at start, +1 at the end |
    | 5.. | the last ``n`` commands sent, newest first (normalised, 2 each) | as actions |

    ω₀ is the model's fastest rate (70.7 rad/s for the seed sail). ``n`` is 0 without
    light delay; with it, ``n`` is the largest round trip in control steps, so the
    commands still in flight are part of the observation (what a delay-compensating
    controller would predict with). With ``light_delay`` entries 0-3 are the state
    as seen ``D/c`` ago, and with ``sensor_noise_std`` they are noisy.

    ## Rewards

    With ``ρ(p) = clip(log10(p / 10 nrad), -2, 3)``:

    - each step: ``-ρ(envelope) / N`` where *envelope* is the largest ``|V⊥|/Vz`` the
      sail would reach with the current beam command held (``N`` = steps in the window);
    - at the last step, in addition: ``-ρ(pointing at cut-off) + 1`` if it succeeds;
    - on divergence: ``-10`` and the episode terminates.

    On LightSail-v0 LQR collects about ``+4.9`` per episode, the passive sail ``+0.9``.

    ## Starting State

    At launch, uniform in ``X ∈ ±5 mm, Vx ∈ ±0.1 m/s, θ ∈ ±2 mrad, ω ∈ ±10 µrad/s``
    (``start_half_widths``; the deep-dish tasks use ±3 cm and ±0.6 m/s laterally, see
    ``sail_env.tasks``); ``reset(options={"initial_state": {...}})`` sets it instead
    (missing keys are zero). With ``control_start_s > 0`` the state is propagated, with
    the disturbances, from launch to the start of control. At the seed sail, a tilt θ
    moves the equilibrium to ``X = θ (2R − Lc)`` = 2 cm per 2 mrad, so the passive sail
    fails on about 40 % of these starts.

    ## Episode End

    1. Termination: the end of the control window; the flight is then scored at cut-off.
       ``info["terminal_pointing_rad"]``, ``info["terminal_envelope_rad"]`` and
       ``info["is_success"]`` (pointing ≤ 10 nrad) are set.
    2. Termination: divergence: the sail leaves the beam (``|X|`` or ``|Lc θ|`` beyond
       the aperture radius) or the small-angle regime (``|θ| > 0.05 rad``), during the
       window or the coast. ``info["diverged"] = True``, ``is_success = False``.

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``config`` | ``"seed"`` | a :class:`SailConfig` or a preset name (``seed``, ``deep_dish``, ``flat``) |
    | ``max_beam_offset_m`` | 0.02 | beam offset at action +1 |
    | ``max_beam_tilt_rad`` | 0.002 | beam tilt at action +1 |
    | ``start_half_widths`` | see above | uniform start half-widths ``(X, Vx, θ, ω)`` |
    | ``sensor_noise_std``, ``beam_jitter_m``, ``push_noise``, ``cutoff_jitter_s``, ``light_delay``, ``parameter_spread`` | off | see :class:`Disturbances` |
    | ``render_mode`` | None | ``"rgb_array"`` or ``"human"`` |

    ``info["state"]`` holds the true state in SI (``x``, ``vx``, ``theta``, ``omega``) and
    ``info["t"]`` the flight time, at every step.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 30}

    def __init__(
        self,
        config: SailConfig | str = "seed",
        render_mode: str | None = None,
        *,
        max_beam_offset_m: float = 0.02,
        max_beam_tilt_rad: float = 2e-3,
        start_half_widths: tuple[float, float, float, float] = DEFAULT_START_HALF_WIDTHS,
        sensor_noise_std: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0),
        beam_jitter_m: float = 0.0,
        push_noise: float = 0.0,
        cutoff_jitter_s: float = 0.0,
        light_delay: bool = False,
        parameter_spread: float = 0.0,
    ) -> None:
        if isinstance(config, str):
            if config not in PRESETS:
                raise ValueError(f"config must be a SailConfig or one of {sorted(PRESETS)}, got {config!r}")
            config = PRESETS[config]
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        for name, value in (("max_beam_offset_m", max_beam_offset_m), ("max_beam_tilt_rad", max_beam_tilt_rad)):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        start_half_widths = tuple(float(w) for w in start_half_widths)
        if len(start_half_widths) != 4 or not all(math.isfinite(w) and w >= 0 for w in start_half_widths):
            raise ValueError(f"start_half_widths must be 4 finite values >= 0, got {start_half_widths}")
        self.nominal_config = config
        self.disturbances = Disturbances(sensor_noise_std, beam_jitter_m, push_noise, cutoff_jitter_s,
                                         light_delay, parameter_spread)
        self.action_scale = np.array([max_beam_offset_m, max_beam_tilt_rad])
        self.start_half_widths = np.array(start_half_widths)
        self.render_mode = render_mode

        self._set_model(config)
        self.nominal_model = self.model
        nominal_rate = max([*self.model.stability.frequencies, self.model.stability.growth_rate])
        self.state_scale = np.array([POSITION_SCALE_M, POSITION_SCALE_M * nominal_rate,
                                     TILT_SCALE_RAD, TILT_SCALE_RAD * nominal_rate])
        self.n_steps = config.control_steps
        # Round trip at the end of the window, with a step of margin each way for the
        # parameter draw (the ground station knows the range, so the delay is known).
        self.history_length = 2 * (self.delay_steps(self.n_steps) + 1) if light_delay else 0
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.observation_space = spaces.Box(-OBSERVATION_LIMIT, OBSERVATION_LIMIT,
                                            (5 + 2 * self.history_length,), np.float32)
        self._renderer: SailRenderer | None = None
        self._state = np.zeros(4)

    # ------------------------------------------------------------------ model set-up
    def _set_model(self, config: SailConfig) -> None:
        """Build the propagators one configuration needs (cached while it stays the same)."""
        self.config = config
        self.model = PlanarModel(config)
        self._phi, self._gamma = self.model.discretize(config.control_step_s)
        self._envelope = EnvelopeEstimator(self.model)

    def _randomised_config(self) -> SailConfig:
        spread = self.disturbances.parameter_spread
        if spread == 0:
            return self.nominal_config
        nominal = self.nominal_config
        names = ("sail_mass_kg", "craft_mass_kg", "strut_length_m", "com_distance_m", "curvature_radius_m")
        factors = self.np_random.uniform(1 - spread, 1 + spread, len(names))
        return nominal.replace(**{n: float(getattr(nominal, n) * f) for n, f in zip(names, factors)})

    def _time(self, step: int) -> float:
        return self.config.control_start_s + step * self.config.control_step_s

    def delay_steps(self, step: int) -> int:
        """One-way light delay at control step ``step``, in whole control steps.

        The observation at ``step`` shows the state of step ``step − delay_steps(step)``;
        the command sent at step ``j`` acts during every step ``s`` with
        ``s − delay_steps(s) = j`` (the newest arrived command is held). Ranging tells a
        ground station the distance, so controllers may use this.
        """
        if not self.disturbances.light_delay:
            return 0
        delay = one_way_light_delay_s(self.config.axial_acceleration_m_s2, self._time(step))
        return round(delay / self.config.control_step_s)

    # ------------------------------------------------------------------ Gymnasium API
    def reset(self, *, seed: int | None = None,
              options: Mapping[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        options = dict(options or {})
        config = self._randomised_config()
        if config is not self.config:
            self._set_model(config)
        jitter = self.disturbances.cutoff_jitter_s
        cutoff = config.beam_cutoff_s + (self.np_random.uniform(-jitter, jitter) if jitter else 0.0)
        self.cutoff_s = float(np.clip(cutoff, config.control_start_s + config.control_window_s,
                                      None))
        self._step = 0
        self._commands: list[np.ndarray] = []
        self._diverged = False
        launch_state = self._initial_state(options.get("initial_state"))

        # Propagate from launch to the earliest state the first (delayed) observation shows.
        lag = self.delay_steps(0)
        noise = self.disturbances.white_noise(config.control_step_s)
        pre_control = config.control_start_s - lag * config.control_step_s
        mean, cov = propagate_moments(self.model, launch_state, np.zeros((4, 4)), np.zeros(2),
                                      pre_control, noise)
        state = sample_gaussian(self.np_random, mean, cov) if cov.any() else mean
        self._history = [state]
        for _ in range(lag):
            state = self._propagate(state, np.zeros(2))
            self._history.append(state)
        self._history_offset = lag  # self._history[i + lag] is the state at control step i
        self._state = state
        self._trajectory = [(self._time(0), state.copy(), np.zeros(2))]
        info = self._info()
        return self._observation(), info

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        action = np.asarray(action, dtype=np.float64).reshape(-1)
        if action.shape != (2,):
            raise ValueError(f"action must have shape (2,), got {action.shape}")
        if not np.all(np.isfinite(action)):
            raise ValueError(f"action must be finite, got {action}")
        if self._diverged or self._step >= self.n_steps:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        self._commands.append(np.clip(action, -1.0, 1.0) * self.action_scale)
        applied = self._applied_input(self._step)
        self._state = self._propagate(self._state, applied)
        self._step += 1
        self._history.append(self._state)
        self._trajectory.append((self._time(self._step), self._state.copy(), applied))

        if self._check_divergence(self._state):
            return self._finish_diverged()
        vz = self.model.equilibrium_speed(self.cutoff_s)
        envelope = self._envelope.peak_speed(self._state, applied) / vz
        reward = -_log_ratio(envelope) / self.n_steps
        info = self._info()
        info["envelope_rad"] = envelope
        terminated = self._step >= self.n_steps
        if terminated:
            final_state, final_input = self._coast()
            if final_state is None:
                return self._finish_diverged()
            pointing = pointing_error(self.model, final_state, self.cutoff_s)
            success = pointing <= POINTING_TOLERANCE_RAD
            reward += -_log_ratio(pointing) + (SUCCESS_BONUS if success else 0.0)
            info.update(
                terminal_pointing_rad=pointing,
                terminal_envelope_rad=self._envelope.peak_speed(final_state, final_input) / vz,
                is_success=bool(success),
                diverged=False,
                cutoff_s=self.cutoff_s,
                terminal_state=_named(final_state),
            )
        if self.render_mode == "human":
            self.render()
        return self._observation(), float(reward), terminated, False, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; set render_mode='rgb_array' or 'human'")
            return None
        if self._renderer is None:
            self._renderer = SailRenderer(self.render_mode, self.metadata["render_fps"])
        return self._renderer.draw(self.config, self._trajectory, self.cutoff_s, self.action_scale)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # ------------------------------------------------------------------ helpers for agents
    def observation_to_state(self, observation: np.ndarray) -> np.ndarray:
        """The (possibly delayed and noisy) measured SI state inside an observation."""
        return np.asarray(observation[:4], dtype=np.float64) * self.state_scale

    def input_to_action(self, beam_input: np.ndarray) -> np.ndarray:
        """Normalised action for a physical beam input ``(d [m], ψ [rad])``, clipped."""
        return np.clip(np.asarray(beam_input) / self.action_scale, -1.0, 1.0).astype(np.float32)

    # ------------------------------------------------------------------ internals
    def _initial_state(self, given: Mapping[str, float] | None) -> np.ndarray:
        if given is None:
            return self.np_random.uniform(-self.start_half_widths, self.start_half_widths)
        unknown = set(given) - set(STATE_NAMES)
        if unknown:
            raise ValueError(f"initial_state keys must be among {STATE_NAMES}, got {sorted(unknown)}")
        state = np.array([float(given.get(name, 0.0)) for name in STATE_NAMES])
        if not np.all(np.isfinite(state)):
            raise ValueError(f"initial_state must be finite, got {dict(given)}")
        return state

    def _applied_input(self, step: int) -> np.ndarray:
        """The command that reaches the sail during ``step`` (zero before any arrives)."""
        sent = step - self.delay_steps(step)
        if sent < 0:
            return np.zeros(2)
        return self._commands[min(sent, len(self._commands) - 1)]

    def _propagate(self, state: np.ndarray, beam_input: np.ndarray) -> np.ndarray:
        """One control step, with the per-step jitter and push noise if switched on."""
        dist = self.disturbances
        if dist.beam_jitter_m:
            beam_input = beam_input + np.array([dist.beam_jitter_m * self.np_random.standard_normal(), 0.0])
        if not dist.push_noise:
            return self._phi @ state + self._gamma @ beam_input
        factor = 1.0 + dist.push_noise * self.np_random.standard_normal()
        a_push, b_push = self.model.push_sensitivity
        a = self.model.A + (factor - 1.0) * a_push
        phi, gamma = zoh_discretize(a, factor * b_push, self.config.control_step_s)
        return phi @ state + gamma @ beam_input

    def _check_divergence(self, state: np.ndarray) -> bool:
        """Whether the sail has left the beam or the small-angle regime (NaN counts as left)."""
        radius = self.config.aperture_radius_m
        x, theta = float(state[X]), float(state[THETA])
        inside = (abs(x) <= radius and abs(self.config.com_distance_m * theta) <= radius
                  and abs(theta) <= MAX_TILT_RAD)
        return not inside

    def _coast(self) -> tuple[np.ndarray | None, np.ndarray]:
        """From the end of the window to cut-off: commands in flight, then the last held.

        Returns ``(None, input)`` if the sail diverges on the way. The coast is split
        into pieces short enough that an unstable sail cannot overflow before it is caught.
        """
        state, step = self._state, self._step
        while step - self.delay_steps(step) < len(self._commands) - 1:
            state = self._propagate(state, self._applied_input(step))
            step += 1
        held = self._commands[-1]
        remaining = self.cutoff_s - self._time(step)
        growth = self.model.stability.growth_rate
        pieces = max(1, math.ceil(remaining * growth / 20.0))
        noise = self.disturbances.white_noise(self.config.control_step_s)
        for _ in range(pieces):
            mean, cov = propagate_moments(self.model, state, np.zeros((4, 4)), held,
                                          remaining / pieces, noise)
            state = sample_gaussian(self.np_random, mean, cov) if cov.any() else mean
            if self._check_divergence(state):
                return None, held
        return state, held

    def _finish_diverged(self) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self._diverged = True
        info = self._info()
        info.update(terminal_pointing_rad=math.inf, terminal_envelope_rad=math.inf,
                    is_success=False, diverged=True, cutoff_s=self.cutoff_s)
        return self._observation(), DIVERGENCE_PENALTY, True, False, info

    def _observation(self) -> np.ndarray:
        shown = self._step - self.delay_steps(self._step) + self._history_offset
        measured = self._history[max(shown, 0)]
        if self.disturbances.any_sensor_noise:
            measured = measured + self.disturbances.sample_sensor_noise(self.np_random)
        progress = 2.0 * self._step / self.n_steps - 1.0
        recent = np.zeros((self.history_length, 2))
        if self.history_length:
            sent = self._commands[::-1][: self.history_length]
            if sent:
                recent[: len(sent)] = np.array(sent) / self.action_scale
        # Finite: one step ago the state was inside the beam, and one linear step keeps it finite.
        obs = np.concatenate([measured / self.state_scale, [progress], recent.ravel()])
        return np.clip(obs, -OBSERVATION_LIMIT, OBSERVATION_LIMIT).astype(np.float32)

    def _info(self) -> dict[str, Any]:
        return {"state": _named(self._state), "t": self._time(self._step)}


def _named(state: np.ndarray) -> dict[str, float]:
    return {name: float(v) for name, v in zip(STATE_NAMES, state)}


def _log_ratio(pointing: float) -> float:
    """``log10(pointing / tolerance)`` clipped to :data:`LOG_RATIO_RANGE`."""
    low, high = LOG_RATIO_RANGE
    if pointing <= 0:
        return low
    return min(max(math.log10(pointing / POINTING_TOLERANCE_RAD), low), high)
