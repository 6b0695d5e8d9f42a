"""The rigid 3D sail as the episode core sees it: its linearisation, batched (docs/physics.md §9).

:class:`RigidFlight` is the task's physics: a :class:`~sail_env.physics.rigid3d.RigidSailConfig`
(shape, beam, materials, masses), the spin, the optional power command and the timing.
:class:`RigidPlant` is the 8-state, 4-input linear model of
:func:`~sail_env.physics.rigid3d.linearise` at the nominal configuration behind the
:class:`~sail_env.physics.plant.LinearPlant` interface: the exact step, the envelope and the
coast are the planar plant's code. The surface quadrature runs once per plant; a parameter
draw scales the mass, the inertia tensor and the beam power, which only rescales rows of the
radiation wrench's Jacobian (no quadrature per reset).

A power command ``u₅`` (relative power) scales every radiation term: ``A(u₅) = K + (1 + u₅) A_rad``
and ``B(u₅) = (1 + u₅) B`` (``A_rad = ∂A/∂ln P``, ``K`` the kinematics and the gyroscopic
coupling). Each step is exact in ``u₅`` to ``O(u₅⁵)`` through the push expansion of
:func:`~sail_env.physics.linear.push_expansion` (to fourth order: ~1e-13 of the step's largest
entry at ±10 %, against 1e-6 to second order; measured in the tests against ``expm``), which also
carries the push noise. The axial speed the pointing divides by is
the nominal push's: a ±10 % power command during the 1 s window changes ``Vz`` at a 600 s
cut-off by at most 0.02 %.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sail_env.physics.config import SEED
from sail_env.physics.linear import LinearModel, mode_rates, push_expansion, zoh_discretize
from sail_env.physics.noise import moment_generator, moment_growth_rate
from sail_env.physics.plant import MAX_TILT_RAD, LinearPlant, PlantParams
from sail_env.physics.pointing import envelope_table
from sail_env.physics.rigid3d.body import INPUT_NAMES, RigidSail
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.flight import Flight, fly
from sail_env.physics.rigid3d.linearise import RATES, STATE_NAMES, linearise

#: The factors a parameter spread draws, in draw order (one uniform factor each).
SPREAD_FIELDS = ("mass", "inertia", "beam_power")
#: Order of the push expansion with a power command (its error is the next term).
POWER_EXPANSION_ORDER = 4
#: Longest piece of a relativistic coast [s]: each piece holds the power factor at its middle.
#: Over the realistic task's 589 s coast the lateral velocity at cut-off is then within 0.8 % of
#: an integration of the time-varying linear model (2 s: 0.15 %, 10 s: 2.7 %; docs/physics.md §14).
COAST_SEGMENT_S = 5.0
X, Y, VX, VY, THETA_X, THETA_Y = range(6)


@dataclasses.dataclass(frozen=True)
class RigidFlight:
    """What the 3D tasks fly: the sail and beam, its spin, the power command and the timing.

    Attributes:
        sail: The :class:`RigidSailConfig` (default: the seed's dish in its flat-top beam).
        spin_rad_s: Spin about the sail axis [rad/s]; it couples the tilt axes (gyroscopic).
        power_control: Relative beam power change at action ±1 of a fifth input (0: no
            power input).
        relativistic: The axial flight follows the relativistic law with the Doppler factor
            (:func:`~sail_env.physics.rigid3d.flight.fly`): the push and every radiation term fall
            along the flight by the power factor ``(1−β)/(1+β)``.
        ground_jitter_rad: Standard deviation of the ground station's pointing angle per control
            step: the spot moves by ``D(t)·δ`` at the sail on both axes (docs/physics.md §12).
        beam_cutoff_s, control_step_s, control_window_s, control_start_s: As in
            :class:`~sail_env.physics.config.SailConfig` (the seed's defaults).
    """

    sail: RigidSailConfig = RigidSailConfig()
    spin_rad_s: float = 0.0
    power_control: float = 0.0
    relativistic: bool = False
    ground_jitter_rad: float = 0.0
    beam_cutoff_s: float = SEED.beam_cutoff_s
    control_step_s: float = SEED.control_step_s
    control_window_s: float = SEED.control_window_s
    control_start_s: float = SEED.control_start_s

    def __post_init__(self) -> None:
        if not isinstance(self.sail, RigidSailConfig):
            raise ValueError(f"sail must be a RigidSailConfig, got {self.sail!r}")
        if not isinstance(self.relativistic, bool):
            raise ValueError(f"relativistic must be a bool, got {self.relativistic!r}")
        for field in dataclasses.fields(self)[1:]:
            if field.name == "relativistic":
                continue
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"{field.name} must be a finite real number, got {value!r}")
        for name in ("beam_cutoff_s", "control_step_s", "control_window_s"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.ground_jitter_rad < 0:
            raise ValueError(f"ground_jitter_rad must be >= 0, got {self.ground_jitter_rad}")
        if not 0 <= self.power_control <= 0.5:
            raise ValueError(f"power_control must be in [0, 0.5], got {self.power_control}")
        if self.control_start_s < 0:
            raise ValueError(f"control_start_s must be >= 0, got {self.control_start_s}")
        if self.control_window_s < self.control_step_s:
            raise ValueError(f"control_window_s must be >= control_step_s ({self.control_step_s} s), "
                             f"got {self.control_window_s}")
        if self.control_start_s + self.control_window_s > self.beam_cutoff_s:
            raise ValueError(f"control_start_s + control_window_s must be <= beam_cutoff_s ({self.beam_cutoff_s} s), "
                             f"got {self.control_start_s + self.control_window_s}")

    @property
    def window_middle_s(self) -> float:
        """Flight time of the control window's middle: where the window's model is taken."""
        return self.control_start_s + 0.5 * self.control_window_s

    @property
    def control_steps(self) -> int:
        """Number of control steps in the window (rounded to whole steps)."""
        return max(1, round(self.control_window_s / self.control_step_s))


class RigidPlant(LinearPlant):
    """Batched linearised 3D sail (:mod:`sail_env.physics.rigid3d`) for the episode core.

    Args:
        flight: The nominal :class:`RigidFlight`.
        parameter_spread: Relative half-width of a uniform per-episode draw of the total mass,
            the inertia tensor and the beam power (:data:`SPREAD_FIELDS`).
        beam_jitter_m: Standard deviation of the beam's offset per control step, on each axis.
        push_noise: Relative standard deviation of the push per control step.
    """

    state_names = STATE_NAMES
    state_units = ("m", "m", "m/s", "m/s", "rad", "rad", "rad/s", "rad/s")
    spread_fields = SPREAD_FIELDS
    jitter_inputs = (0, 1)
    velocity_rows = (VX, VY)

    def __init__(self, flight: RigidFlight, parameter_spread: float = 0.0, beam_jitter_m: float = 0.0,
                 push_noise: float = 0.0) -> None:
        self.config = flight
        self.sail = RigidSail(flight.sail)
        self.linearisation = lin = linearise(self.sail, spin=flight.spin_rad_s)
        power = flight.power_control > 0
        self.input_names = INPUT_NAMES + (("beam_power",) if power else ())
        self.input_units = ("m", "m", "rad", "rad") + (("1",) if power else ())
        self.input_ranges = {"1": flight.power_control} if power else {}
        # The power input has no column of B: it acts through A (and B) parametrically.
        b = np.zeros((8, len(self.input_names)))
        b[:, :4] = lin.B
        self.kinematics = lin.A - lin.push_sensitivity
        self.radiation = lin.push_sensitivity
        self.radiation_b = b
        self.nominal_acceleration = lin.push_n / lin.mass_kg
        self.fixed_state = {"spin": flight.spin_rad_s}  # a launch state may name it, not change it
        self.flight: Flight | None = None
        self.ground_jitter_rad = flight.ground_jitter_rad
        self.time_varying = flight.relativistic or flight.ground_jitter_rad > 0
        if self.time_varying:
            # Without diffraction the flight of a sail with r times the nominal F/m is the nominal
            # one at r t (d(γβ)/dt = r F₀ f(β) / (m₀ c)): one integration serves every draw.
            fastest = (1 + parameter_spread) / (1 - parameter_spread)
            self.flight = fly(self.sail, 2.0 * flight.beam_cutoff_s * fastest, relativistic=flight.relativistic)
        window = self.power_factor(np.ones(1), np.full(1, flight.window_middle_s))[0]
        nominal_a = self.kinematics + window * self.radiation if flight.relativistic else lin.A.copy()
        nominal_b = window * b
        super().__init__(LinearModel(nominal_a, nominal_b, (window * self.radiation, nominal_b)),
                         flight.control_step_s, parameter_spread, beam_jitter_m, push_noise)
        self.noisy = self.noisy or self.ground_jitter_rad > 0

    @property
    def power_control(self) -> bool:
        return self.n_inputs > 4

    @property
    def acceleration_m_s2(self) -> float:
        return self.nominal_acceleration

    @property
    def max_acceleration_m_s2(self) -> float:
        s = self.parameter_spread
        return self.nominal_acceleration * (1 + s) / (1 - s)

    # ------------------------------------------------------------------ parameters
    def _matrices(self, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, A_rad)`` (k, ·, ·) for factors (k, 3) of mass, inertia and beam power."""
        mass, inertia, power = factors.T
        # Translational rows scale as power / mass, rotational ones as power / inertia; the
        # gyroscopic coupling I_a Ω / I_t does not change when the whole tensor scales.
        rows = np.ones((len(factors), 8))
        rows[:, [RATES[0], RATES[1]]] = (power / mass)[:, None]
        rows[:, [RATES[2], RATES[3]]] = (power / inertia)[:, None]
        # The window holds the power factor at its middle (it changes by < 1e-3 within it).
        rows *= self.power_factor(power / mass, np.full(len(factors), self.config.window_middle_s))[:, None]
        a_rad = rows[:, :, None] * self.radiation
        return self.kinematics + a_rad, rows[:, :, None] * self.radiation_b, a_rad

    def _build(self, factors: np.ndarray, shared: bool) -> PlantParams:
        if shared:
            a, b, a_rad = self.nominal.A[None], self.nominal.B[None], self.radiation[None]
        else:
            a, b, a_rad = self._matrices(factors)
        n, m = b.shape[-2:]
        if self.power_control or self.push_noise:
            order = POWER_EXPANSION_ORDER if self.power_control else 2
            coeffs = push_expansion(a, b, a_rad, b, self.dt, order)
        else:
            phi, gamma = self.nominal.discretize(self.dt) if shared else zoh_discretize(a, b, self.dt)
            coeffs = np.concatenate([phi, gamma], axis=-1)[:, None]
        step = coeffs.reshape(len(a), -1, n + m)
        growth, freqs = mode_rates(a)
        table = envelope_table(a, b, rows=self.velocity_rows, mode_rates=(growth, freqs))
        if self.push_noise:
            # Only the push noise multiplies the state (parametric excitation). The spread's growth
            # is the window model's: along the flight the radiation terms scale by at most
            # (1 + power_control) / (power factor), far inside the margin between a piece's e^20
            # and overflow.
            growth = np.maximum(growth, moment_growth_rate(a, b, self.white_noise, (a - self.kinematics, b)))
        c = self.config.sail
        limits = np.tile([c.aperture_radius_m, min(c.aperture_radius_m / c.com_distance_m, MAX_TILT_RAD)],
                         (len(a), 1))
        acceleration = self.nominal_acceleration * factors[:, 2] / factors[:, 0]
        return PlantParams(a, b, step, table, acceleration, limits, growth, shared)

    # ------------------------------------------------------------------ physics
    def _push(self, u: np.ndarray, push: np.ndarray | None) -> np.ndarray | None:
        """The relative push error ε of a step: the power command times the push noise."""
        if not self.power_control:
            return push
        return u[:, 4] if push is None else (1.0 + u[:, 4]) * (1.0 + push) - 1.0

    def step(self, p: PlantParams, x: np.ndarray, u: np.ndarray, push: np.ndarray | None = None) -> np.ndarray:
        return super().step(p, x, u, self._push(u, push))

    def start_limits(self) -> np.ndarray:
        c = self.config.sail
        tilt = min(c.aperture_radius_m / c.com_distance_m, MAX_TILT_RAD)
        return np.repeat([c.aperture_radius_m, c.aperture_radius_m / self.dt, tilt, tilt / self.dt], 2)

    def diverged(self, p: PlantParams, x: np.ndarray) -> np.ndarray:
        """The CoM has left the beam's aperture (``√(x² + y²) > a``) or the tilt the small-angle
        regime or the aperture (``√(θx² + θy²) > min(a/Lc, MAX_TILT_RAD)``); NaN counts as left."""
        offset = np.hypot(x[:, X], x[:, Y])
        tilt = np.hypot(x[:, THETA_X], x[:, THETA_Y])
        return ~((offset <= p.limits[:, 0]) & (tilt <= p.limits[:, 1]))

    def power_factor(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The Doppler power factor at flight time ``t`` of sails with ``ratio`` times the nominal
        axial acceleration (one without the relativistic law)."""
        if self.flight is None:
            return np.ones(len(ratio))
        return self.flight.power_factor(self._flight_time(ratio, t))

    def _flight_time(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        scaled = ratio * t
        if np.any(scaled > self.flight.duration_s):
            raise ValueError(f"flight time {float(np.max(t))} s is beyond the integrated flight "
                             f"({self.flight.duration_s} s at the nominal push)")
        return scaled

    def speed(self, p: PlantParams, t: np.ndarray) -> np.ndarray:
        """Axial speed ``Vz`` [m/s] of the centred sail: ``a t`` (Newtonian) or the relativistic law
        with the Doppler factor (:mod:`sail_env.physics.relativity`)."""
        if self.flight is None or not self.flight.relativistic:
            return p.acceleration * t
        return self.flight.speed(self._flight_time(p.acceleration / self.nominal_acceleration, t))

    def pointing(self, p: PlantParams, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Flight direction ``|V⊥| / Vz`` [rad] over both axes if the beam is cut at ``t``."""
        return np.hypot(x[:, VX], x[:, VY]) / self.speed(p, t)

    def coast_pieces(self, p: PlantParams, duration: np.ndarray) -> np.ndarray:
        """:meth:`LinearPlant.coast_pieces`, and with the relativistic push pieces of at most
        :data:`COAST_SEGMENT_S`."""
        pieces = super().coast_pieces(p, duration)
        if self.flight is None:
            return pieces
        return np.maximum(pieces, np.ceil(duration / COAST_SEGMENT_S).astype(np.int64))

    def _coast_params(self, p: PlantParams, u: np.ndarray, t: np.ndarray) -> PlantParams:
        """The window's model with the held power command and, relativistically, the power factor
        at ``t`` (relative to the window's) folded into every radiation term:
        ``A = K + s A_rad``, ``B = s B`` (docs/physics.md §14)."""
        scale = np.ones(len(u))
        if self.power_control:
            scale = scale * (1.0 + u[:, 4])
        if self.flight is not None:
            ratio = p.acceleration / self.nominal_acceleration * np.ones(len(u))
            scale = scale * (self.power_factor(ratio, t)
                             / self.power_factor(ratio, np.full(len(u), self.config.window_middle_s)))
        if np.all(scale == 1.0):
            return p
        a_rad = p.a - self.kinematics
        return dataclasses.replace(p, a=self.kinematics + scale[:, None, None] * a_rad,
                                   b=scale[:, None, None] * p.b, shared=False)

    def _moment_generator(self, p: PlantParams, u: np.ndarray, t: np.ndarray) -> np.ndarray:
        a_rad = p.a - self.kinematics
        psd = None if not self.ground_jitter_rad else self.jitter_std(p, t)[:, 0] ** 2 * self.dt
        return moment_generator(p.a, p.b, u, self.white_noise, (a_rad, p.b), self.jitter_inputs, psd)

    @property
    def jittered(self) -> bool:
        return bool(self.beam_jitter_m or self.ground_jitter_rad)

    def jitter_std(self, p: PlantParams, t: np.ndarray) -> np.ndarray | float:
        """The landing jitter and the ground jitter ``D(t)·δ`` (independent; ``D`` of the draw's flight)."""
        if not self.ground_jitter_rad:
            return self.beam_jitter_m
        ratio = p.acceleration / self.nominal_acceleration
        # β_r(t) = β(r t), so D_r(t) = ∫ β(r s) c ds = D(r t) / r.
        distance = self.flight.distance(self._flight_time(ratio, t)) / ratio
        return np.hypot(self.beam_jitter_m, distance * self.ground_jitter_rad)[:, None]

    def rate_scale(self) -> float:
        """The nominal model's fastest rate [1/s]: the time scale of the observations."""
        growth, freqs = mode_rates(self.nominal.A)
        return float(np.nanmax([*freqs, growth]))
