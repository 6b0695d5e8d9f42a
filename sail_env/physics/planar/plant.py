"""The planar model (:mod:`sail_env.physics.planar.model`) as the episode core's batched plant."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sail_env.physics.disturbance import Disturbance
from sail_env.physics.linear import push_expansion, zoh_discretize
from sail_env.physics.linear_plant import MAX_TILT_RAD, LinearPlant, PlantParams
from sail_env.physics.noise import moment_growth_rate
from sail_env.physics.planar.config import SailConfig
from sail_env.physics.planar.model import (BEAM_OFFSET, INPUT_NAMES, STATE_NAMES, THETA, VX, X, PlanarModel,
                                           push_sensitivity, rates, system_matrices)
from sail_env.physics.pointing import envelope_table
from sail_env.physics.seed import moment_of_inertia

#: The parameters a spread draws, in draw order (one uniform factor each).
SPREAD_FIELDS = ("sail_mass_kg", "craft_mass_kg", "strut_length_m", "com_distance_m", "curvature_radius_m")


class PlanarPlant(LinearPlant):
    """Batched physics of the planar model (:mod:`sail_env.physics.planar.model`) for the episode core.

    Args:
        config: The nominal configuration.
        parameter_spread: Relative half-width of a uniform per-episode draw of each of
            :data:`SPREAD_FIELDS`.
        push_noise: Relative standard deviation of the push per control step.
        disturbances: The random disturbances (:mod:`sail_env.physics.disturbances`; the planar
            sail carries the beam's landing jitter).

    Raises ``ValueError`` for a spread that could draw an invalid configuration or a disturbance
    the model cannot carry.
    """

    #: What sets the fastest flight (named when a task would pass light speed).
    light_speed_settings = "push_force_n and beam_cutoff_s"
    state_names = STATE_NAMES
    state_units = ("m", "m/s", "rad", "rad/s")
    input_names = INPUT_NAMES
    input_units = ("m", "rad")
    input_ranges: dict[str, float] = {}
    spread_fields = SPREAD_FIELDS
    jitter_inputs = (BEAM_OFFSET,)
    velocity_rows = (VX,)
    #: The sail has left the beam (``|X|`` beyond the aperture) or ``|θ|`` beyond ``min(a/Lc, MAX_TILT_RAD)``.
    divergence_groups = ((X,), (THETA,))

    def __init__(self, config: SailConfig, parameter_spread: float = 0.0, push_noise: float = 0.0,
                 disturbances: Sequence[Disturbance] = ()) -> None:
        self.config = config
        self.parameter_spread = parameter_spread
        self._check_spread_box()
        disturbances = self.check_disturbances(disturbances)
        super().__init__(PlanarModel(config), config.control_step_s, parameter_spread, push_noise, disturbances)

    @property
    def aperture_radius_m(self) -> float:
        return self.config.aperture_radius_m

    def _check_spread_box(self) -> None:
        """Every configuration the spread can draw must be valid (the corners are the worst)."""
        s, c = self.parameter_spread, self.config
        if c.strut_length_m * (1 - s) < c.com_distance_m * (1 + s):
            raise ValueError(f"parameter_spread={s} can draw strut_length_m < com_distance_m: needs "
                             f"strut_length_m >= com_distance_m (1 + s) / (1 - s) = "
                             f"{c.com_distance_m * (1 + s) / (1 - s):.4g} m, got {c.strut_length_m}")
        if c.curvature_radius_m * (1 - s) < c.aperture_radius_m:
            raise ValueError(f"parameter_spread={s} can draw curvature_radius_m < aperture_radius_m "
                             f"({c.aperture_radius_m} m): needs curvature_radius_m >= "
                             f"{c.aperture_radius_m / (1 - s):.4g} m, got {c.curvature_radius_m}")

    def start_limits(self) -> np.ndarray:
        c = self.config
        tilt = min(c.aperture_radius_m / (c.com_distance_m * (1 + self.parameter_spread)), MAX_TILT_RAD)
        return np.array([c.aperture_radius_m, c.aperture_radius_m / self.dt, tilt, tilt / self.dt])

    def _build(self, factors: np.ndarray, shared: bool) -> PlantParams:
        c = self.config
        sail, craft, strut, lc, radius = (getattr(c, name) * factors[:, i] for i, name in enumerate(SPREAD_FIELDS))
        if shared:  # exactly the nominal model's matrices
            a, b = self.nominal.A[None], self.nominal.B[None]
        else:
            a, b = system_matrices(c.push_force_n, sail + craft, moment_of_inertia(sail, craft, lc, strut), lc, radius)
        if self.push_noise:
            coeffs = push_expansion(a, b, *push_sensitivity(a, b), self.dt)
        else:
            phi, gamma = self.nominal.discretize(self.dt) if shared else zoh_discretize(a, b, self.dt)
            coeffs = np.concatenate([phi, gamma], axis=-1)[:, None]
        step = coeffs.reshape(len(factors), -1, 6)
        modes = rates(a)
        growth = modes[0]
        if self.noisy:
            growth = np.maximum(growth, moment_growth_rate(a, b, self.white_noise, push_sensitivity(a, b)))
        # |Lc θ| ≤ a and |θ| ≤ MAX_TILT_RAD in one bound on |θ|.
        limits = np.stack([np.full(len(lc), c.aperture_radius_m), np.minimum(c.aperture_radius_m / lc, MAX_TILT_RAD)], 1)
        table = envelope_table(a, b, rows=self.velocity_rows, mode_rates=modes)
        return PlantParams(a, b, step, table, c.push_force_n / (sail + craft), limits, growth, shared)

    @property
    def acceleration_m_s2(self) -> float:
        """Nominal axial acceleration [m/s²] (what the light-delay rule assumes)."""
        return self.config.axial_acceleration_m_s2

    @property
    def max_acceleration_m_s2(self) -> float:
        """Largest axial acceleration a parameter draw can give (the lightest sail)."""
        return self.config.axial_acceleration_m_s2 / (1 - self.parameter_spread)

    def speed(self, p: PlantParams, t: np.ndarray) -> np.ndarray:
        """Axial speed ``Vz = a t`` [m/s] (Newtonian, as in the seed's planar model)."""
        return p.acceleration * t

    def pointing(self, p: PlantParams, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Flight direction ``|Vx| / Vz`` [rad] if the beam is cut at ``t``."""
        return np.abs(x[:, VX]) / self.speed(p, t)

    def _push_terms(self, p: PlantParams) -> tuple[np.ndarray, np.ndarray]:
        """Every force term scales with the push (:func:`~sail_env.physics.planar.model.push_sensitivity`)."""
        return push_sensitivity(p.a, p.b)

    def rate_scale(self) -> float:
        """The nominal model's fastest rate [1/s]: the time scale of the observations."""
        stability = self.nominal.stability
        return max([*stability.frequencies, stability.growth_rate])
