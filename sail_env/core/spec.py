"""What defines a task apart from its physics: timing, action and observation scales, start
distribution, light delay and randomisation (:mod:`sail_env.physics.randomisation`). Controllers read
it instead of an env's internals."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence

import numpy as np

from sail_env.core.delay import delay_steps
from sail_env.core.plant import Plant
from sail_env.physics.checks import check_below_light_speed, real_number
from sail_env.physics.disturbance import Disturbance
from sail_env.physics.mission import one_way_light_delay_s
from sail_env.physics.randomisation import Randomisation, finite_nonnegative, randomisation

#: Observation scales: the state is divided by these (rates by the model's fastest rate too).
POSITION_SCALE_M = 1e-2
TILT_SCALE_RAD = 1e-3
#: Round-off allowed between times computed as ``start + steps · dt`` and configured times.
TIME_TOLERANCE_S = 1e-9
#: What builds a task's plant from its physical randomness: ``make_plant(parameter_spread,
#: push_noise, sources)`` (``sources``: :attr:`~sail_env.physics.randomisation.Randomisation.sources`),
#: e.g. ``functools.partial(PlanarPlant, config)``.
PlantFactory = Callable[[float, float, tuple[Disturbance, ...]], Plant]
#: Most further coasts an episode's score may be averaged over (``expected_paths``).
MAX_PATHS = 1024


def check_expected_paths(value: object) -> int:
    """``expected_paths`` as an int in [0, :data:`MAX_PATHS`]; ``ValueError`` naming it otherwise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or not 0 <= value <= MAX_PATHS:
        raise ValueError(f"expected_paths must be an int in [0, {MAX_PATHS}], got {value!r}")
    return int(value)


class EpisodeSpec:
    """A task: the plant and everything the episode core adds to it (validated here).

    The spec knows no concrete sail model: the env that builds it passes the plant's factory
    (:data:`PlantFactory`), which receives the physical randomness.

    Attributes:
        config: The plant's configuration (its timing: ``control_start_s``, ``control_step_s``,
            ``control_steps``, ``beam_cutoff_s``).
        plant: The batched physics (the :class:`~sail_env.core.plant.Plant` contract).
        nominal: The nominal linear model (what a controller designs on).
        randomisation: The :class:`~sail_env.physics.randomisation.Randomisation`.
        light_delay: Whether observations and commands are delayed by the light travel time
            ``D(t)/c`` each way, rounded to whole control steps. The round trip at the end of the
            window must not exceed the window.
        dt, n_steps: Control step [s] and number of steps in the control window.
        action_scale: Physical input at action +1 (planar ``(d [m], ψ [rad])``).
        state_scale: Divides the SI state in the observation.
        start_half_widths: Uniform start distribution at launch, one per state (planar ``(X, Vx, θ, ω)``).
        history_length: Commands shown in the observation (the largest round trip with
            light delay, with a step of margin each way for the parameter draw; else 0).
        max_delay: Largest one-way delay [steps] any parameter draw can see up to the
            last command's arrival (sizes the core's buffers).
        expected_paths: The score's further coasts ``K``: at each episode's end, ``K`` more coasts
            from the window's end (the state after the commands in flight) estimate the probability
            of success given it (``info["expected_success"]``); 0: none. They draw from a stream of
            their own, so the episode's numbers are the same with them or without.
    """

    def __init__(self, make_plant: PlantFactory, *, start_half_widths: Sequence[float],
                 max_beam_offset_m: float = 0.02, max_beam_tilt_rad: float = 2e-3,
                 light_delay: bool = False, randomisation: Randomisation = Randomisation(),
                 expected_paths: int = 0) -> None:
        scales = [real_number(v, name) for name, v in (("max_beam_offset_m", max_beam_offset_m),
                                                      ("max_beam_tilt_rad", max_beam_tilt_rad))]
        for name, value in zip(("max_beam_offset_m", "max_beam_tilt_rad"), scales):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        if not isinstance(light_delay, (bool, np.bool_)):
            raise ValueError(f"light_delay must be True or False, got {light_delay!r}")
        self.light_delay = bool(light_delay)
        self.expected_paths = check_expected_paths(expected_paths)
        self.randomisation = randomisation
        self.plant: Plant = make_plant(randomisation.parameter_spread, randomisation.push_noise, randomisation.sources)
        self.config = config = self.plant.config
        n = self.plant.n_states
        widths = finite_nonnegative(start_half_widths, "start_half_widths", n)
        if randomisation.any_sensor_noise and len(randomisation.sensor_noise_std) != n:
            raise ValueError(f"sensor_noise_std must be {n} values (one per state), got {randomisation.sensor_noise_std}")
        self.nominal = self.plant.nominal
        self.dt = config.control_step_s
        self.n_steps = config.control_steps
        physical = {"m": scales[0], "rad": scales[1], **self.plant.input_ranges}
        self.action_scale = np.array([physical[unit] for unit in self.plant.input_units])
        self.start_half_widths = np.array(widths)
        self.sensor_noise_std = np.array(randomisation.sensor_noise_std) if randomisation.any_sensor_noise else np.zeros(n)
        # A sail with no stiffness at all (neutral, in a spot wider than it) has no rate of its own: the
        # window's inverse then, so that no observation divides by zero.
        rate = self.plant.rate_scale() or 1.0 / (self.n_steps * self.dt)
        scales = {"m": POSITION_SCALE_M, "m/s": POSITION_SCALE_M * rate, "rad": TILT_SCALE_RAD,
                  "rad/s": TILT_SCALE_RAD * rate}
        self.state_scale = np.array([scales[unit] for unit in self.plant.state_units])
        fastest = self.plant.max_acceleration_m_s2
        if self.light_delay:
            self._check_round_trip(fastest)
            self.history_length = 2 * (int(self.delay_steps(self.n_steps)) + 1)
            self.max_delay = int(delay_steps(fastest, config.control_start_s, self.dt,
                                             self.n_steps + self.history_length)) + 1
        else:
            self.history_length = self.max_delay = 0
        self._check_cutoff()
        settings = self.plant.light_speed_settings
        check_below_light_speed(fastest, config.beam_cutoff_s + randomisation.cutoff_jitter_s,
                                f"{settings} (fastest draw of parameter_spread, latest of cutoff_jitter_s)",
                                settings.replace(" and ", " or "))
        self.start_limits = self.plant.start_limits()
        self.check_start(self.start_half_widths, "start_half_widths")

    def _check_round_trip(self, fastest_m_s2: float) -> None:
        """The light's round trip at the end of the window must not outlast the window: else no
        observation could show most commands' effects, and the observation, which lists the
        commands in flight, would be longer than the episode."""
        end = self.config.control_start_s + self.n_steps * self.dt
        round_trip = 2 * one_way_light_delay_s(fastest_m_s2, end) / self.dt
        if not round_trip <= self.n_steps:
            raise ValueError(
                f"light_delay: the round trip 2 D/c at the end of the control window ({end:.6g} s) is "
                f"{round_trip:.6g} steps, more than the window's {self.n_steps} steps; start control earlier "
                f"(control_start_s) or lengthen control_window_s")

    def check_start(self, states: np.ndarray, name: str) -> None:
        """Refuse start states (..., n) beyond :attr:`start_limits`, naming ``name`` and the limit. The
        components of a plant's ``radial_pairs`` (the 3D sail's x and y axes) are limited in their
        length ``√(x² + y²)``, as divergence is; a box of half-widths is checked at its corner."""
        n = self.plant.n_states
        size = np.abs(np.asarray(states, dtype=np.float64)).reshape(-1, n)
        labels = list(self.plant.state_names)
        for i, j in self.plant.radial_pairs:
            size[:, i] = size[:, j] = np.hypot(size[:, i], size[:, j])
            labels[i] = labels[j] = f"√({labels[i]}² + {labels[j]}²)"
        beyond = size > self.start_limits
        if beyond.any():
            k = int(np.flatnonzero(beyond.any(axis=0))[0])
            label = labels[k] if labels[k].startswith("√") else f"|{labels[k]}|"
            raise ValueError(
                f"{name}: {label} must be <= {self.start_limits[k]:.4g} (inside the beam and "
                f"the small-angle regime, and not leaving them within one step), got {size[:, k].max():.4g}")

    def _check_cutoff(self) -> None:
        """The earliest cut-off must come after the last command has reached the sail (to within
        :data:`TIME_TOLERANCE_S`, so that a window ending exactly at the cut-off is accepted)."""
        c, jitter = self.config, self.randomisation.cutoff_jitter_s
        last_arrival = c.control_start_s + (self.n_steps + self.max_delay) * self.dt
        largest = c.beam_cutoff_s - last_arrival
        if largest < -TIME_TOLERANCE_S:
            raise ValueError(
                f"beam_cutoff_s - cutoff_jitter_s = {c.beam_cutoff_s - jitter:.6g} s must be >= the end of "
                f"control with the commands in flight, control_start_s + (steps + delay) * dt = "
                f"{last_arrival:.6g} s")
        if jitter > largest + TIME_TOLERANCE_S:
            raise ValueError(
                f"cutoff_jitter_s must be in [0, {max(largest, 0.0):.6g}] s: the earliest cut-off must come after the "
                f"last command has reached the sail ({last_arrival:.6g} s into the flight; the cut-off is at "
                f"{c.beam_cutoff_s:.6g} s), got {jitter}")

    @property
    def window_middle_s(self) -> float:
        """Flight time [s] of the control window's middle (where slowly varying disturbances are sized)."""
        return self.config.control_start_s + 0.5 * self.n_steps * self.dt

    def window_step_noise(self, gamma: np.ndarray) -> np.ndarray:
        """Covariance (n, n) of the state change that the beam offsets and the impacts
        (:attr:`Randomisation.sources <sail_env.physics.randomisation.Randomisation.sources>`) cause over one control step of the nominal sail in the
        window's middle, ``gamma`` (n, m) being the step's input matrix: ``σ² Γ_J Γ_Jᵀ`` over the
        jittered inputs ``J``, plus ``rate · dt · kick²`` on the impulse rows. What a design's
        process noise takes of them (the push noise, which multiplies the state, is the design's own)."""
        std, kicks = self._window_noise_sizes
        covariance = np.zeros((self.plant.n_states,) * 2)
        if std:
            columns = gamma[:, list(self.plant.jitter_inputs)]
            covariance += std**2 * columns @ columns.T
        rows = list(self.plant.impulse_rows)
        covariance[rows, rows] += kicks
        return covariance

    @functools.cached_property
    def _window_noise_sizes(self) -> tuple[float, np.ndarray]:
        """The beam offsets' per-step standard deviation and the impulse rows' per-step variance
        ``rate · dt · kick²`` of the nominal sail in the window's middle: computed once (a design per
        episode, as the oracles make, would otherwise build the nominal model's tables every time)."""
        plant = self.plant
        nominal = plant.params(np.ones((1, plant.n_factors)))
        middle = np.array([self.window_middle_s])
        std = float(np.ravel(plant.jitter_std(nominal, middle))[0]) if plant.jittered else 0.0
        if not plant.impulse_rows:
            return std, np.zeros(0)
        rate, kick = plant.impact_rate_and_std(nominal, middle)
        return std, rate[0] * self.dt * kick[0] ** 2

    @property
    def observation_size(self) -> int:
        return self.plant.n_states + 1 + self.plant.n_inputs * self.history_length

    @property
    def ring_lengths(self) -> tuple[int, int, int]:
        """What an episode keeps for the light delay (each backend sizes its buffers by it): the sent
        commands (the observation's history, and every command still in flight), the true states (the
        oldest one a delayed observation can show) and the steps whose delay is tabled (to the last
        command's arrival); ``(1, 1, 0)`` without light delay."""
        if not self.light_delay:
            return 1, 1, 0
        return (max(self.history_length, self.max_delay + 1) + 1, self.max_delay + 2,
                self.n_steps + self.max_delay + 2)

    def delay_steps(self, step: np.ndarray | int, acceleration_m_s2: np.ndarray | float | None = None) -> np.ndarray:
        """One-way light delay in steps at control ``step`` (zero without light delay); see
        :func:`sail_env.core.delay.delay_steps`. The nominal acceleration unless given."""
        if not self.light_delay:
            return np.zeros(np.shape(step), dtype=np.int64)
        accel = self.plant.acceleration_m_s2 if acceleration_m_s2 is None else acceleration_m_s2
        return delay_steps(accel, self.config.control_start_s, self.dt, step)

    def observation_to_state(self, observation: np.ndarray) -> np.ndarray:
        """The (possibly delayed and noisy) measured SI state inside an observation."""
        return np.asarray(observation[..., :self.plant.n_states], dtype=np.float64) * self.state_scale

    def input_to_action(self, beam_input: np.ndarray) -> np.ndarray:
        """Normalised action for a physical input (planar ``(d [m], ψ [rad])``), clipped."""
        return np.clip(np.asarray(beam_input) / self.action_scale, -1.0, 1.0).astype(np.float32)


def task_spec(make_plant: PlantFactory, default_start_half_widths: Sequence[float], *,
              start_half_widths: Sequence[float] | None = None, max_beam_offset_m: float = 0.02,
              max_beam_tilt_rad: float = 2e-3, light_delay: bool = False, expected_paths: int = 0,
              **randomness: object) -> EpisodeSpec:
    """The spec of an env's episode keywords: the beam limits, the start box (the env's
    ``default_start_half_widths`` unless given), the light delay, the score's paths and the randomisation's keywords
    (:mod:`sail_env.physics.randomisation`: its own and the registered disturbances'). The one place
    every env's shared keywords are spelled out (their table is in the randomisation's module and the
    env docstrings); an unknown one is a ``TypeError`` naming it."""
    given, unknown = randomisation(randomness)
    if unknown:
        raise TypeError(f"unexpected keyword argument {sorted(unknown)[0]!r}")
    widths = default_start_half_widths if start_half_widths is None else start_half_widths
    return EpisodeSpec(make_plant, start_half_widths=widths, max_beam_offset_m=max_beam_offset_m,
                       max_beam_tilt_rad=max_beam_tilt_rad, light_delay=light_delay, randomisation=given,
                       expected_paths=expected_paths)
