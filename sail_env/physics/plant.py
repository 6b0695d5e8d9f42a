"""The planar sail as the episode core sees it: batched physics behind a small interface.

A :class:`PlanarPlant` knows the nominal configuration, how far its parameters may be
drawn from it, and the disturbances that act on the physics (beam jitter and push
noise, per control step and as white noise over longer propagations). It knows nothing
of light delay, observations, rewards or episodes (``sail_env.core``).

Every method works on a batch of environments: states ``x`` (k, 4), inputs ``u`` (k, 2)
and :class:`PlantParams` whose arrays lead with k, or with 1 when all environments
share one model (no parameter spread), which keeps the common step a single matrix
product.
"""

from __future__ import annotations

import dataclasses
import numpy as np
import scipy.linalg

from sail_env.physics.config import SailConfig, moment_of_inertia
from sail_env.physics.linear import push_expansion, sample_gaussian, sample_uniform, zoh_discretize
from sail_env.physics.noise import (WhiteNoise, mean_and_covariance, moment_generator, moment_growth_rate,
                                    second_moment)
from sail_env.physics.planar import (INPUT_NAMES, STATE_NAMES, THETA, VX, X, PlanarModel, push_sensitivity,
                                     rates, system_matrices)
from sail_env.physics.pointing import envelope_table, peak_speed

#: The sail has left the small-angle regime the model is valid in.
MAX_TILT_RAD = 0.05
#: The parameters a spread draws, in draw order (one uniform factor each).
SPREAD_FIELDS = ("sail_mass_kg", "craft_mass_kg", "strut_length_m", "com_distance_m", "curvature_radius_m")
#: Largest growth ``e^GROWTH_PER_PIECE`` of one piece of a long propagation: from inside the
#: aperture an unstable sail then stays finite until the divergence test catches it.
GROWTH_PER_PIECE = 20.0


@dataclasses.dataclass
class PlantParams:
    """Per-environment arrays (leading axis k, or 1 when shared)."""

    a: np.ndarray  # (·, 4, 4) system matrix
    b: np.ndarray  # (·, 4, 2) input matrix
    step: np.ndarray  # (·, P·4, 6) one control step: rows of [Φ Γ] for ε⁰ (and ε¹, ε² with push noise)
    envelope: np.ndarray  # (·, S, 6) look-ahead table of |Vx| (pointing.envelope_table)
    acceleration: np.ndarray  # (·,) axial acceleration F/m [m/s²]
    limits: np.ndarray  # (·, 2) largest |X| [m] and |θ| [rad] inside the beam and the small-angle regime
    growth: np.ndarray  # (·,) largest growth rate [1/s] of the state (with noise: of its spread, if faster)
    shared: bool

    def take(self, index: np.ndarray) -> PlantParams:
        """The parameters of environments ``index`` (shared parameters are returned as they are)."""
        if self.shared:
            return self
        return PlantParams(*(getattr(self, f.name)[index] for f in dataclasses.fields(self)[:-1]), shared=False)

    def put(self, index: np.ndarray, other: PlantParams) -> None:
        """Overwrite environments ``index`` with ``other`` (both per-environment)."""
        for field in dataclasses.fields(self)[:-1]:
            mine, theirs = getattr(self, field.name), getattr(other, field.name)
            if mine.shape[1:] != theirs.shape[1:]:  # envelope tables of another length
                width = max(mine.shape[1], theirs.shape[1])
                mine, theirs = _pad_rows(mine, width), _pad_rows(theirs, width)
                setattr(self, field.name, mine)
            mine[index] = theirs


def _pad_rows(table: np.ndarray, width: int) -> np.ndarray:
    """Repeat the last row of each (k, S, 6) table up to ``width`` rows (the maximum is unchanged)."""
    if table.shape[1] == width:
        return table
    return np.concatenate([table, np.repeat(table[:, -1:], width - table.shape[1], axis=1)], axis=1)


class PlanarPlant:
    """Batched physics of the planar model (:mod:`sail_env.physics.planar`) for the episode core.

    Args:
        config: The nominal configuration.
        parameter_spread: Relative half-width of a uniform per-episode draw of each of
            :data:`SPREAD_FIELDS`.
        beam_jitter_m: Standard deviation of the beam's landing offset per control step, at most
            the aperture radius (the linear model assumes the beam lands on the sail).
        push_noise: Relative standard deviation of the push per control step.

    Raises ``ValueError`` for a spread that could draw an invalid configuration or a jitter
    wider than the aperture.
    """

    state_names = STATE_NAMES
    input_names = INPUT_NAMES

    def __init__(self, config: SailConfig, parameter_spread: float = 0.0, beam_jitter_m: float = 0.0,
                 push_noise: float = 0.0) -> None:
        self.config = config
        self.nominal = PlanarModel(config)
        self.parameter_spread = parameter_spread
        self.beam_jitter_m = beam_jitter_m
        self.push_noise = push_noise
        self.dt = config.control_step_s
        self._check_spread_box()
        if beam_jitter_m > config.aperture_radius_m:
            raise ValueError(f"beam_jitter_m must be <= aperture_radius_m ({config.aperture_radius_m} m): the "
                             f"beam must land on the sail, got {beam_jitter_m}")
        self.white_noise = WhiteNoise.from_step_std(beam_jitter_m, push_noise, self.dt)
        self.noisy = bool(beam_jitter_m or push_noise)
        self._shared = None if parameter_spread else self._build(np.ones((1, len(SPREAD_FIELDS))), shared=True)

    @property
    def n_draws(self) -> int:
        """How many uniform numbers :meth:`draw` takes from a generator."""
        return len(SPREAD_FIELDS) if self.parameter_spread else 0

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

    # ------------------------------------------------------------------ parameters
    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """Per-episode factors of :data:`SPREAD_FIELDS` (all one without spread; draws nothing then)."""
        if not self.parameter_spread:
            return np.ones(len(SPREAD_FIELDS))
        return sample_uniform(rng, 1 - self.parameter_spread, 1 + self.parameter_spread, len(SPREAD_FIELDS))

    def params(self, factors: np.ndarray) -> PlantParams:
        """Parameters for environments with the given factors (k, 5); shared without spread."""
        return self._shared if self._shared is not None else self._build(factors, shared=False)

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
        growth, _ = rates(a)
        if self.noisy:
            growth = np.maximum(growth, moment_growth_rate(a, b, self.white_noise))
        # |Lc θ| ≤ a and |θ| ≤ MAX_TILT_RAD in one bound on |θ|.
        limits = np.stack([np.full(len(lc), c.aperture_radius_m), np.minimum(c.aperture_radius_m / lc, MAX_TILT_RAD)], 1)
        return PlantParams(a, b, step, envelope_table(a, b), c.push_force_n / (sail + craft), limits, growth, shared)

    # ------------------------------------------------------------------ physics
    def step(self, p: PlantParams, x: np.ndarray, u: np.ndarray, push: np.ndarray | None = None) -> np.ndarray:
        """One control step with ``u`` held; ``push`` (k,) is the relative push error ε of the step."""
        z = np.concatenate([x, u], axis=-1)
        y = z @ p.step[0].T if p.shared else np.matmul(p.step, z[:, :, None])[:, :, 0]
        if push is None:
            return y[:, :4]
        eps = push[:, None]
        return y[:, :4] + eps * (y[:, 4:8] + eps * y[:, 8:12])

    def diverged(self, p: PlantParams, x: np.ndarray) -> np.ndarray:
        """The sail has left the beam (``|X|`` or ``|Lc θ|`` beyond the aperture) or the small-angle
        regime; NaN counts as left."""
        inside = np.abs(x[:, [X, THETA]]) <= p.limits
        return ~(inside[:, 0] & inside[:, 1])

    def peak_speed(self, p: PlantParams, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Largest ``|Vx|`` [m/s] the sail would reach with ``u`` held (the envelope)."""
        return peak_speed(p.envelope[0] if p.shared else p.envelope, x, u)

    def speed(self, p: PlantParams, t: np.ndarray) -> np.ndarray:
        """Axial speed ``Vz = a t`` [m/s] (Newtonian, as in the seed's planar model)."""
        return p.acceleration * t

    def pointing(self, p: PlantParams, x: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Flight direction ``|Vx| / Vz`` [rad] if the beam is cut at ``t``."""
        return np.abs(x[:, VX]) / self.speed(p, t)

    def coast_pieces(self, p: PlantParams, duration: np.ndarray) -> np.ndarray:
        """How many pieces :meth:`coast` splits each propagation into (one unless the sail, or with
        noise its spread, grows by more than ``e^GROWTH_PER_PIECE``)."""
        return np.maximum(1, np.ceil(duration * p.growth / GROWTH_PER_PIECE).astype(np.int64))

    def coast(self, p: PlantParams, x: np.ndarray, u: np.ndarray, duration: np.ndarray,
              normals: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Propagate ``duration`` (k,) seconds with ``u`` held and the disturbances as white noise.

        Without noise the step is exact. With it, the first two moments are exact
        (:mod:`sail_env.physics.noise`) and the end state is drawn from that Gaussian with
        ``normals`` (k, pieces, 4). An unstable sail is propagated in
        :meth:`coast_pieces` pieces and checked after each; returns ``(x, diverged)``.
        """
        pieces = self.coast_pieces(p, duration)
        piece = duration / pieces
        diverged = np.zeros(len(x), dtype=bool)
        if self.noisy:
            generator = moment_generator(p.a, p.b, u, self.white_noise) * piece[:, None, None]
            propagator = scipy.linalg.expm(generator)
        elif p.shared and np.all(piece == piece[0]):
            phi, gamma = self.nominal.discretize(float(piece[0]))
        else:
            phi, gamma = zoh_discretize(p.a, p.b, piece)
        for i in range(int(pieces.max())):
            if self.noisy:
                start = second_moment(x, np.zeros((len(x), 4, 4)))
                mean, cov = mean_and_covariance(np.einsum("kij,kj->ki", propagator, start))
                moved = sample_gaussian(mean, cov, normals[:, i])
            else:
                moved = np.einsum("...ij,...j->...i", phi, x) + np.einsum("...ij,...j->...i", gamma, u)
            active = (i < pieces) & ~diverged
            x = np.where(active[:, None], moved, x)
            diverged |= active & self.diverged(p, x)
        return x, diverged

    def rate_scale(self) -> float:
        """The nominal model's fastest rate [1/s]: the time scale of the observations."""
        stability = self.nominal.stability
        return max([*stability.frequencies, stability.growth_rate])
