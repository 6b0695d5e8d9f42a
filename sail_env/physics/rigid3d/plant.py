"""The rigid 3D sail as the episode core sees it: its linearisation, batched (docs/physics.md §9).

:class:`RigidTaskConfig` is the task's physics: a :class:`~sail_env.physics.rigid3d.RigidSailConfig`
(shape, beam, materials, masses), the spin, the optional power command and the timing. "Flight" means
the sail's axial trajectory (:mod:`~sail_env.physics.rigid3d.flight`) and nothing else; the
configuration was called ``RigidFlight`` before version 0.4 (that name still works, with a warning).
:class:`RigidPlant` is the 8-state, 4-input linear model of
:func:`~sail_env.physics.rigid3d.linearise` at the nominal configuration behind the
:class:`~sail_env.physics.linear_plant.LinearPlant` interface: the exact step, the envelope and the
coast are the planar plant's code. The surface quadrature runs once per plant; a parameter
draw scales the mass, the inertia tensor and the beam power, which only rescales rows of the
radiation wrench's Jacobian (no quadrature per reset). Along the flight the Doppler factor and,
beyond the diffraction length, the spot's widening change the radiation terms: each draw's flight
comes from :class:`~sail_env.physics.rigid3d.flight.DrawFlights`, the terms in a widened spot from a
:class:`~sail_env.physics.rigid3d.scales.ScaleTable` built once (docs/physics.md §14).

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
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from sail_env.physics import seed
from sail_env.physics.checks import boolean, check_timing, real_number
from sail_env.physics.disturbance import Disturbance
from sail_env.physics.linear import LinearModel, mode_rates, push_expansion, zoh_discretize
from sail_env.physics.noise import WhiteNoise, moment_growth_rate
from sail_env.physics.linear_plant import MAX_TILT_RAD, LinearPlant, PlantParams
from sail_env.physics.pointing import envelope_table
from sail_env.physics.rigid3d.body import INPUT_NAMES, RigidSail
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.flight import DrawFlights, draw_flights
from sail_env.physics.rigid3d.limits import (MAX_POWER_CONTROL, check_flight, check_spin, farthest_distance_m,
                                             fastest_flight)
from sail_env.physics.rigid3d.damping import damped_linearisation
from sail_env.physics.rigid3d.linearise import RATES, STATE_NAMES, Linearisation
from sail_env.physics.rigid3d.scales import ScaleTable, scale_table

#: The factors a parameter spread draws, in draw order (one uniform factor each).
SPREAD_FIELDS = ("mass", "inertia", "beam_power")
#: Order of the push expansion with a power command (its error is the next term).
POWER_EXPANSION_ORDER = 4
#: Longest piece of a relativistic coast [s]: each piece holds the power factor at its middle.
#: Over the realistic task's 589 s coast the lateral velocity at cut-off is then within 0.8 % of
#: an integration of the time-varying linear model (2 s: 0.15 %, 10 s: 2.7 %; docs/physics.md §14).
COAST_SEGMENT_S = 5.0
#: Halvings that locate where a draw's spot starts widening within a coast piece (5 s / 2⁵⁰).
BISECTIONS = 50
X, Y, VX, VY, THETA_X, THETA_Y, OMEGA_X, OMEGA_Y = range(8)


@dataclasses.dataclass(frozen=True)
class RigidTaskConfig(seed.Timing):
    """The 3D task's physics: the sail and beam, its spin, the power command and the timing.

    Attributes:
        sail: The :class:`RigidSailConfig` (default: the seed's dish in its flat-top beam).
        spin_rad_s: Spin about the sail axis [rad/s]; it couples the tilt axes (gyroscopic).
        power_control: Relative beam power change at action ±1 of a fifth input (0: no
            power input).
        relativistic: The axial flight follows the relativistic law with the Doppler factor
            (:func:`~sail_env.physics.rigid3d.flight.fly`): the push and every radiation term fall
            along the flight by the power factor ``(1−β)/(1+β)``.
        diffraction_length_m: ``L0``: beyond it the spot widens as ``D/L0`` with its intensity
            falling as ``(L0/D)²`` (Kulkarni, Lubin & Zhang 2018), and every radiation term follows
            (docs/physics.md §7, §14); ``inf`` (default): the spot never widens.
        payload_offset_m: Distance of the payload from the sail axis (along x), at most the
            aperture radius: the CoM leaves the axis by ``e·m_craft/m`` and the push exerts a
            constant torque about it (docs/physics.md §15).
        velocity_terms: The radiation forces' terms of order v/c (Doppler and aberration,
            :mod:`~sail_env.physics.rigid3d.damping`; docs/physics.md §13): the only passive
            damping a mirror has, of order 1e-3 e-folds over a flight.
        beam_cutoff_s, control_step_s, control_window_s, control_start_s: As in
            the planar sail's (the seed's design point, :mod:`~sail_env.physics.seed`).
    """

    sail: RigidSailConfig = RigidSailConfig()
    spin_rad_s: float = 0.0
    power_control: float = 0.0
    relativistic: bool = False
    diffraction_length_m: float = math.inf
    payload_offset_m: float = 0.0
    velocity_terms: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.sail, RigidSailConfig):
            raise ValueError(f"sail must be a RigidSailConfig, got {self.sail!r}")
        for name in ("relativistic", "velocity_terms"):
            object.__setattr__(self, name, boolean(getattr(self, name), name))
        for field in dataclasses.fields(RigidTaskConfig):  # a subclass checks its own fields
            if field.name in ("sail", "relativistic", "velocity_terms"):
                continue
            value = real_number(getattr(self, field.name), field.name)
            if math.isnan(value) or (math.isinf(value) and field.name != "diffraction_length_m"):
                raise ValueError(f"{field.name} must be a finite real number, got {value!r}")
            object.__setattr__(self, field.name, value)  # NumPy scalars and ints stored as float
        if not self.diffraction_length_m > 0:
            raise ValueError(f"diffraction_length_m must be > 0 (inf: no diffraction), got {self.diffraction_length_m}")
        for name in ("beam_cutoff_s", "control_step_s", "control_window_s"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0 <= self.payload_offset_m <= self.sail.aperture_radius_m:
            raise ValueError(f"payload_offset_m must be in [0, aperture_radius_m = {self.sail.aperture_radius_m}], "
                             f"got {self.payload_offset_m}")
        if not 0 <= self.power_control <= MAX_POWER_CONTROL:
            raise ValueError(f"power_control must be in [0, {MAX_POWER_CONTROL}] (0: no power input), "
                             f"got {self.power_control}")
        check_spin(self.spin_rad_s, self.control_step_s)
        check_timing(self.control_start_s, self.control_step_s, self.control_window_s, self.beam_cutoff_s)

    @property
    def window_middle_s(self) -> float:
        """Flight time of the control window's middle: where the window's model is taken."""
        return self.control_start_s + 0.5 * self.control_window_s



@dataclasses.dataclass(frozen=True)
class FlightModel:
    """What a coast along the flight reads of a :class:`RigidPlant` and its draws (:meth:`RigidPlant.
    flight_model`): the tables, the model's fixed parts, and per draw (K, ...) the window's model and
    how its radiation terms scale; the JAX backend's coast (``sail_env.jax.along``) is handed these."""

    flights: DrawFlights
    scales: ScaleTable | None  # the widened spot's terms (None: the spot never widens)
    kinematics: np.ndarray  # (n, n) the part of A no radiation term scales
    radiation: np.ndarray  # (n, n) the nominal sail's radiation part of A in the unwidened spot
    radiation_b: np.ndarray  # (n, c) and of B, with the constant term's column
    kink_distances: np.ndarray  # (J,) distances [m] where the model has a kink (the spot widens, an edge)
    nominal_acceleration: float  # [m/s²]: a draw's is ``ratio`` times it
    relativistic_speed: bool  # the axial speed is the flight's (else ``a t``)
    reads_distance: bool  # a beam disturbance grows with the distance
    noise: WhiteNoise  # the push noise's intensity
    dt: float  # the control step [s]: the beam jitter's intensity is σ² dt
    config: RigidTaskConfig
    linearisation: Linearisation
    ratio: np.ndarray  # (K,) each draw's F/m over the nominal
    rows: np.ndarray  # (K, n) each draw's scaling of the radiation terms' rows
    window_a: np.ndarray  # (K, n, n) the window's model
    window_b: np.ndarray  # (K, n, c)
    window_power: np.ndarray  # (K,) the Doppler power factor at the window's middle
    window_scale: np.ndarray  # (K,) the spot's scale there
    growth: np.ndarray  # (K,) the draw's growth rate [1/s]
    #: Each draw's own sail terms where the sail itself is drawn (the uncertain tasks' ``DrawTerms``,
    #: :mod:`~sail_env.physics.rigid3d.uncertainty`); None: every draw flies the nominal sail's.
    draw: Any = None

    def payload_column(self, radiation: Any, push: Any, xp: Any = np) -> Any:
        """:func:`payload_term` of a spot's radiation part of ``A`` and its push, in the array module ``xp``."""
        return payload_term(self.config, self.linearisation, radiation, push, xp=xp)


@dataclasses.dataclass
class RigidParams(PlantParams):
    """:class:`PlantParams` and each draw's scaling ``rows`` (·, 8) of the radiation terms' rows
    (power/mass on ``v̇``, power/inertia on ``ω̇``, no Doppler factor): the model in another spot
    is ``K + p(t) rows R(s)``; and the draw's ``factors`` (·, n_factors), from which a subclass
    with more drawn quantities builds ``R(s)``."""

    rows: np.ndarray
    factors: np.ndarray


def payload_term(config: RigidTaskConfig, lin: Linearisation, radiation: np.ndarray,
                 push: np.ndarray | float, xp: Any = np) -> np.ndarray:
    """The constant term ``c`` (..., 8) of a payload ``e`` off the axis along x (docs/physics.md §15),
    for the radiation part of ``A`` (..., 8, 8) and the push [N] (...) of a spot; ``xp`` the array module
    (the JAX backend's coast builds it along the flight).

    The CoM sits ``e_c = e m_craft / m`` off the axis, so the sail lies ``e_c`` to −x of it: the
    radiation terms see the CoM offset ``x − e_c``, and the push ``F`` through the axis exerts the
    torque ``F e_c`` about y on the CoM (first order in ``e_c``; the inertia tensor's change is second).
    """
    # Python floats (the same values): weakly typed, so that a float32 model stays float32 under JAX.
    offset = float(config.payload_offset_m * config.sail.craft_mass_kg / lin.mass_kg)
    term = -offset * radiation[..., :, X]
    torque = xp.asarray(push) * offset / float(lin.inertia[0, 0])
    if xp is np:
        term[..., OMEGA_Y] += torque
        return term
    return term.at[..., OMEGA_Y].add(torque)


class RigidPlant(LinearPlant):
    """Batched linearised 3D sail (:mod:`sail_env.physics.rigid3d`) for the episode core.

    Args:
        config: The nominal :class:`RigidTaskConfig`.
        parameter_spread: Relative half-width of a uniform per-episode draw of the total mass,
            the inertia tensor and the beam power (:data:`SPREAD_FIELDS`).
        push_noise: Relative standard deviation of the push per control step.
        disturbances: The random disturbances (:mod:`sail_env.physics.disturbances`): the beam's
            landing and ground pointing jitter on each axis, dust.
    """

    #: What sets the fastest flight (named when a task would pass light speed).
    light_speed_settings = "parameter_spread and cutoff_jitter_s"
    state_names = STATE_NAMES
    state_units = ("m", "m", "m/s", "m/s", "rad", "rad", "rad/s", "rad/s")
    spread_fields = SPREAD_FIELDS
    jitter_inputs = (0, 1)
    #: A constant-term column even without a payload offset (a subclass's drawn constant drive).
    always_biased = False
    velocity_rows = (VX, VY)
    #: The tilt rates (with the lateral speeds, the rows a dust grain kicks).
    tilt_rate_rows = (OMEGA_X, OMEGA_Y)
    #: Components limited together at the start, as divergence limits them: ``√(x² + y²)`` and so on.
    radial_pairs = ((X, Y), (VX, VY), (THETA_X, THETA_Y), (OMEGA_X, OMEGA_Y))
    #: The CoM has left the aperture (``√(x² + y²) > a``) or the tilt the small-angle regime or the
    #: aperture (``√(θx² + θy²) > min(a/Lc, MAX_TILT_RAD)``).
    divergence_groups = ((X, Y), (THETA_X, THETA_Y))

    def __init__(self, config: RigidTaskConfig, parameter_spread: float = 0.0, push_noise: float = 0.0,
                 disturbances: Sequence[Disturbance] = ()) -> None:
        self.config = config
        self.parameter_spread = parameter_spread
        self.sail = RigidSail(config.sail)
        self.linearisation = lin = damped_linearisation(self.sail, spin=config.spin_rad_s,
                                                        velocity_terms=config.velocity_terms)
        check_flight(config, lin, parameter_spread)
        disturbances = self.check_disturbances(disturbances)
        power = config.power_control > 0
        self.input_names = INPUT_NAMES + (("beam_power",) if power else ())
        self.input_units = ("m", "m", "rad", "rad") + (("1",) if power else ())
        self.input_ranges = {"1": config.power_control} if power else {}
        self.biased = config.payload_offset_m > 0 or self.always_biased
        # The power input has no column of B: it acts through A (and B) parametrically. The payload's
        # constant term is a last column with its input held at 1; it scales with the push like B.
        m = len(self.input_names)
        b = np.zeros((8, m + self.biased))
        b[:, :4] = lin.B
        if self.biased:
            b[:, m] = payload_term(config, lin, lin.push_sensitivity, lin.push_n)
        self.kinematics = lin.A - lin.push_sensitivity
        self.radiation = lin.push_sensitivity
        self.radiation_b = b
        self.nominal_acceleration = lin.push_n / lin.mass_kg
        self.fixed_state = {"spin": config.spin_rad_s}  # a launch state may name it, not change it
        self.flights: DrawFlights | None = None
        self.scales: ScaleTable | None = None
        self.diffracting = math.isfinite(config.diffraction_length_m)
        if config.relativistic or self.diffracting or any(d.needs_distance for d in disturbances):
            # The flights of every draw's F/m, to twice the cut-off (the latest a cut-off jitter allows).
            fastest = self.largest_ratio(parameter_spread)
            self.flights = draw_flights(config.sail, 2.0 * config.beam_cutoff_s, config.relativistic,
                                        config.diffraction_length_m, fastest)
            if self.diffracting:
                # A draw's spot is D̃(r t)/(r L0) (DrawFlights): bounded by the farthest node over the slowest draw.
                farthest = max(float(f.distance(f.duration_s)) for f in self.flights.flights)
                self.scales = scale_table(config.sail, farthest * fastest / config.diffraction_length_m,
                                          config.velocity_terms)
        # Impacts' rate and size grow with the sail's speed: the coast holds them piecewise too.
        self.time_varying = self.flights is not None or any(d.channel == "impulse" for d in disturbances)
        self.flight = None if self.flights is None else self.flights.nominal
        ones, middle = np.ones(1), np.full(1, config.window_middle_s)
        window = self.power_factor(ones, middle)[0]
        radiation, inputs = (matrix[0] for matrix in self._radiation(ones, middle))
        nominal_a = self.kinematics + window * radiation if config.relativistic or self.diffracting else lin.A.copy()
        self.nominal_b = window * inputs  # with the constant term's column
        controls = self.nominal_b[:, :m]
        super().__init__(LinearModel(nominal_a, controls, (window * radiation, controls)),
                         config.control_step_s, parameter_spread, push_noise, disturbances)

    @property
    def power_control(self) -> bool:
        return self.n_inputs > 4

    @property
    def acceleration_m_s2(self) -> float:
        return self.nominal_acceleration

    @property
    def max_acceleration_m_s2(self) -> float:
        return self.nominal_acceleration * self.largest_ratio(self.parameter_spread)

    def largest_ratio(self, parameter_spread: float) -> float:
        """The largest ``F/m`` of a draw over the nominal one, and of the nominal over a draw's."""
        return (1 + parameter_spread) / (1 - parameter_spread)

    # ------------------------------------------------------------------ parameters
    def _radiation(self, ratio: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Radiation part of ``A`` (·, 8, 8) and ``B`` (·, 8, m) at the configured power, no Doppler
        factor, in the spot that draws with ``ratio`` times the nominal ``F/m`` see at flight time
        ``t`` (k,): the nominal sail's (1, ·, ·) while no spot has widened."""
        if self.scales is None:
            return self.radiation[None], self.radiation_b[None]
        scale = self.flights.beam_scale(ratio, t)
        if np.all(scale <= 1.0):
            return self.radiation[None], self.radiation_b[None]
        widened, inputs = self.scales.at(scale)
        b = np.zeros((len(scale),) + self.radiation_b.shape)
        b[:, :, :4] = inputs
        if self.biased:
            b[:, :, -1] = payload_term(self.config, self.linearisation, widened, self.scales.push_at(scale))
        near = (scale <= 1.0)[:, None, None]
        return np.where(near, self.radiation, widened), np.where(near, self.radiation_b, b)

    def draw_rows(self, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each draw's scaling ``rows`` (k, 8) of the radiation terms and its ``F/m`` over the nominal
        (k,), for factors (k, n_factors) whose first three are mass, inertia and beam power."""
        mass, inertia, power = factors[:, :3].T
        # Translational rows scale as power / mass, rotational ones as power / inertia; the
        # gyroscopic coupling I_a Ω / I_t does not change when the whole tensor scales.
        rows = np.ones((len(factors), 8))
        rows[:, [RATES[0], RATES[1]]] = (power / mass)[:, None]
        rows[:, [RATES[2], RATES[3]]] = (power / inertia)[:, None]
        return rows, power / mass

    def draw_radiation(self, factors: np.ndarray, ratio: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The radiation terms (:meth:`_radiation`) of draws with ``factors`` at flight time ``t``: the
        nominal sail's (mass, inertia and power only scale rows). A subclass that draws the sail's
        shape or materials gives each draw its own."""
        return self._radiation(ratio, t)

    def _matrices(self, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, A_rad, rows)`` (k, ·, ·) for factors (k, n_factors)."""
        rows, ratio = self.draw_rows(factors)
        # The window holds the power factor and the spot at its middle (the factor changes by < 1e-3 within it).
        middle = np.full(len(factors), self.config.window_middle_s)
        window = rows * self.power_factor(ratio, middle)[:, None]
        radiation, inputs = self.draw_radiation(factors, ratio, middle)
        a_rad = window[:, :, None] * radiation
        return self.kinematics + a_rad, window[:, :, None] * inputs, a_rad, rows

    def _build(self, factors: np.ndarray, shared: bool) -> RigidParams:
        if shared:
            a, b, a_rad = self.nominal.A[None], self.nominal_b[None], self.nominal.push_sensitivity[0][None]
            rows = np.ones((1, 8))
        else:
            a, b, a_rad, rows = self._matrices(factors)
        n, m = b.shape[-2:]
        if self.power_control or self.push_noise:
            order = POWER_EXPANSION_ORDER if self.power_control else 2
            coeffs = push_expansion(a, b, a_rad, b, self.dt, order)
        else:
            exact_nominal = shared and not self.biased
            phi, gamma = self.nominal.discretize(self.dt) if exact_nominal else zoh_discretize(a, b, self.dt)
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
        limits = np.tile([self.aperture_radius_m, self.tilt_limit_rad], (len(a), 1))
        acceleration = self.nominal_acceleration * self.draw_rows(factors)[1]
        return RigidParams(a, b, step, table, acceleration, limits, growth, shared, rows, factors)

    # ------------------------------------------------------------------ physics
    def _push(self, u: np.ndarray, push: np.ndarray | None) -> np.ndarray | None:
        """The relative push error ε of a step: the power command times the push noise."""
        if not self.power_control:
            return push
        return u[:, 4] if push is None else (1.0 + u[:, 4]) * (1.0 + push) - 1.0

    def step(self, p: PlantParams, x: np.ndarray, u: np.ndarray, push: np.ndarray | None = None) -> np.ndarray:
        return super().step(p, x, u, self._push(u, push))

    @property
    def constant_term(self) -> np.ndarray:
        """The nominal model's constant term ``c`` (8,) of the payload offset (zero without it)."""
        return self.nominal_b[:, -1] if self.biased else np.zeros(self.n_states)

    def start_limits(self) -> np.ndarray:
        a, tilt = self.aperture_radius_m, self.tilt_limit_rad
        return np.repeat([a, a / self.dt, tilt, tilt / self.dt], 2)

    @property
    def tilt_limit_rad(self) -> float:
        """Largest tilt [rad] on the beam: the aperture seen from the CoM, at most the small-angle
        regime's :data:`~sail_env.physics.linear_plant.MAX_TILT_RAD`."""
        c = self.config.sail
        return min(c.aperture_radius_m / c.com_distance_m, MAX_TILT_RAD)

    def power_factor(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        """The Doppler power factor at flight time ``t`` of sails with ``ratio`` times the nominal
        axial acceleration (one without the relativistic law)."""
        if self.flights is None:
            return np.ones(len(ratio))
        return self.flights.power_factor(ratio, t)

    def speed(self, p: PlantParams, t: np.ndarray) -> np.ndarray:
        """Axial speed ``Vz`` [m/s] of the centred sail: ``a t`` (Newtonian, fixed spot) or the
        integrated flight: the relativistic law with the Doppler factor
        (:mod:`sail_env.physics.relativity`) and the power lost beyond ``L0``."""
        if self.flights is None or not (self.config.relativistic or self.diffracting):
            return p.acceleration * t
        return self.flights.speed(p.acceleration / self.nominal_acceleration, t)

    def distance_flown(self, p: PlantParams, t: np.ndarray) -> np.ndarray:
        """Distance [m] from the array at flight times ``t`` ((k,) or a grid (k, s)) of each draw's flight."""
        ratio = p.acceleration / self.nominal_acceleration
        return self.flights.distance(ratio.reshape(ratio.shape + (1,) * (np.ndim(t) - 1)), t)

    @property
    def farthest_distance_m(self) -> float:
        """The farthest any draw can be from the array at a cut-off (a Newtonian bound)."""
        return farthest_distance_m(self.config, self.linearisation, self.parameter_spread)

    @property
    def fastest_speed_m_s(self) -> float:
        """The fastest any draw can fly at a cut-off (the same Newtonian bound)."""
        acceleration, horizon = fastest_flight(self.config, self.linearisation, self.parameter_spread)
        return acceleration * horizon

    @property
    def aperture_radius_m(self) -> float:
        return self.config.sail.aperture_radius_m

    def pointing(self, p: PlantParams, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Flight direction ``|V⊥| / Vz`` [rad] over both axes if the beam is cut at ``t``."""
        return np.hypot(x[:, VX], x[:, VY]) / self.speed(p, t)

    def coast_pieces(self, p: PlantParams, duration: np.ndarray) -> np.ndarray:
        """:meth:`LinearPlant.coast_pieces`, and with a model that changes along the flight pieces of
        at most :data:`COAST_SEGMENT_S`."""
        pieces = super().coast_pieces(p, duration)
        if not self.time_varying:
            return pieces
        return np.maximum(pieces, np.ceil(duration / COAST_SEGMENT_S).astype(np.int64))

    def _coast_params(self, p: RigidParams, u: np.ndarray, t: np.ndarray) -> PlantParams:
        """The window's model with the held power command and the power factor at ``t`` (relative to
        the window's) folded into every radiation term: ``A = K + s A_rad``, ``B = s B``; where a
        draw's spot differs from the window's, the radiation terms of that spot
        (docs/physics.md §14)."""
        scale = np.ones(len(u))
        if self.power_control:
            scale = scale * (1.0 + u[:, 4])
        if self.flights is not None:
            ratio = p.acceleration / self.nominal_acceleration * np.ones(len(u))
            middle = np.full(len(u), self.config.window_middle_s)
            if self.scales is not None and np.any(self.flights.beam_scale(ratio, t)
                                                  != self.flights.beam_scale(ratio, middle)):
                rows = p.rows * (scale * self.power_factor(ratio, t))[:, None]
                radiation, inputs = self.draw_radiation(p.factors, ratio, t)
                a_rad = rows[:, :, None] * radiation
                return dataclasses.replace(p, a=self.kinematics + a_rad, b=rows[:, :, None] * inputs, shared=False)
            scale = scale * (self.power_factor(ratio, t) / self.power_factor(ratio, middle))
        if np.all(scale == 1.0):
            return p
        a_rad = p.a - self.kinematics
        return dataclasses.replace(p, a=self.kinematics + scale[:, None, None] * a_rad,
                                   b=scale[:, None, None] * p.b, shared=False)

    def _piece_propagators(self, p: PlantParams, u: np.ndarray, middles: np.ndarray,
                           piece: np.ndarray) -> list[np.ndarray | tuple[np.ndarray, np.ndarray]]:
        """:meth:`LinearPlant._piece_propagators`, each piece split where a draw's spot starts widening
        or a hard beam edge meets the rim within it: the model jumps there, and a piece held at its
        middle would take the wrong side for up to half its length."""
        propagators = super()._piece_propagators(p, u, middles, piece)
        if self.scales is None or not self.scales.kinks:
            return propagators
        k, count = middles.shape
        # Every piece's ends in one read of the flights; only the pieces with a kink are split.
        lo, hi = middles - 0.5 * piece[:, None], middles + 0.5 * piece[:, None]
        ratio = np.repeat(p.acceleration / self.nominal_acceleration * np.ones(k), count)
        cuts = self._kink_times(ratio, lo.ravel(), hi.ravel())
        if cuts is None:
            return propagators
        split = np.any(np.stack(cuts) < hi.ravel(), axis=0).reshape(k, count)
        for j in np.flatnonzero(split.any(axis=0)):
            rows = np.arange(k) * count + j
            total = None
            for start, end in zip([lo[:, j], *(c[rows] for c in cuts)], [*(c[rows] for c in cuts), hi[:, j]]):
                part = super()._piece_propagators(p, u, (0.5 * (start + end))[:, None], end - start)[0]
                if total is None:
                    total = part
                elif self.noisy:
                    total = np.matmul(part, total)
                else:
                    total = (np.matmul(part[0], total[0]), np.einsum("...ij,...j->...i", part[0], total[1]) + part[1])
            propagators[j] = total
        return propagators

    def _kink_times(self, ratio: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray] | None:
        """Times (k,) in ``[lo, hi]`` at which the spot of draws with ``ratio`` (k,) times the nominal
        ``F/m`` reaches a scale where ``A`` jumps (``hi`` where it does not in the piece), in order;
        ``None`` if no draw's does."""
        if self.scales is None or not self.scales.kinks:
            return None
        length = self.config.diffraction_length_m
        cuts = []
        near, far = self.flights.distance(ratio, lo), self.flights.distance(ratio, hi)
        for kink in self.scales.kinks:
            distance = length * math.exp(kink)
            inside = (near < distance) & (distance < far)
            if not inside.any():
                continue
            below, above = lo[inside], hi[inside]
            for _ in range(BISECTIONS):
                half = 0.5 * (below + above)
                short = self.flights.distance(ratio[inside], half) < distance
                below, above = np.where(short, half, below), np.where(short, above, half)
            cut = hi.copy()
            cut[inside] = above
            cuts.append(cut)
        return list(np.sort(cuts, axis=0)) if cuts else None

    def _push_terms(self, p: PlantParams) -> tuple[np.ndarray, np.ndarray]:
        return p.a - self.kinematics, p.b

    def flight_model(self, p: RigidParams) -> FlightModel | None:
        """The :class:`FlightModel` of draws ``p`` (None without the flights' table)."""
        if self.flights is None:
            return None
        k = len(p.acceleration)
        ratio = p.acceleration / self.nominal_acceleration * np.ones(k)
        middle = np.full(k, self.config.window_middle_s)
        length = self.config.diffraction_length_m
        kinks = [] if self.scales is None else [length * math.exp(x) for x in self.scales.kinks]
        return FlightModel(
            flights=self.flights, scales=self.scales, kinematics=self.kinematics, radiation=self.radiation,
            radiation_b=self.radiation_b, kink_distances=np.array(kinks),
            nominal_acceleration=self.nominal_acceleration,
            relativistic_speed=self.config.relativistic or self.diffracting,
            reads_distance=any(d.needs_distance for d in self._beams), noise=self.white_noise, dt=self.dt,
            config=self.config, linearisation=self.linearisation, ratio=ratio, rows=p.rows * np.ones((k, 1)),
            window_a=p.a * np.ones((k, 1, 1)), window_b=p.b * np.ones((k, 1, 1)),
            window_power=self.power_factor(ratio, middle), window_scale=self.flights.beam_scale(ratio, middle),
            growth=p.growth * np.ones(k))

    def rate_scale(self) -> float:
        """The nominal model's fastest rate [1/s]: the time scale of the observations."""
        growth, freqs = mode_rates(self.nominal.A)
        return float(np.nanmax([*freqs, growth]))


def __getattr__(name: str) -> type:
    """The configuration's name before version 0.4, kept a while with a warning."""
    if name == "RigidFlight":
        warnings.warn("RigidFlight is now RigidTaskConfig", DeprecationWarning, stacklevel=2)
        return RigidTaskConfig
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
