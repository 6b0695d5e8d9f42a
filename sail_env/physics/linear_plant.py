"""The sail as the episode core sees it: batched linear physics behind a small interface.

A plant knows the nominal model, how far its parameters may be drawn from it, and the
disturbances that act on the physics (the push noise and the registered random disturbances of
:mod:`sail_env.physics.disturbance`, per control step and as white noise over longer
propagations). It knows nothing of light delay,
observations, rewards or episodes (``sail_env.core``). :class:`LinearPlant` holds what
every linear model shares (the exact step, the envelope, the coast);
``sail_env.physics.planar.plant.PlanarPlant`` is the planar model,
``sail_env.physics.rigid3d.plant.RigidPlant`` the 3D one.

Every method works on a batch of environments: states ``x`` (k, n), inputs ``u`` (k, m)
and :class:`PlantParams` whose arrays lead with k, or with 1 when all environments
share one model (no parameter spread), which keeps the common step a single matrix
product.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
from collections.abc import Mapping, Sequence
from types import MappingProxyType

import numpy as np

from sail_env.physics.blas import one_blas_thread, single_threaded
from sail_env.physics.disturbance import Disturbance
from sail_env.physics.linear import LinearModel, sample_gaussian, zoh_discretize
from sail_env.physics.noise import (WhiteNoise, held_input_generator, mean_and_covariance, moment_generator,
                                    moment_propagator, second_moment)
from sail_env.physics.pointing import peak_speed

#: The sail has left the small-angle regime the model is valid in.
MAX_TILT_RAD = 0.05
#: Largest growth ``e^GROWTH_PER_PIECE`` of one piece of a long propagation: from inside the
#: aperture an unstable sail then stays finite until the divergence test catches it.
GROWTH_PER_PIECE = 20.0
#: Most piece propagators a coast of a time-varying model builds in one call: k environments
#: build ``max(1, COAST_BATCH // k)`` pieces at a time (a few MB of generators).
COAST_BATCH = 128
#: Smallest batch whose step and envelope products a BLAS library could thread (OpenBLAS threads a
#: product above ~2.6e5 multiply-adds; the envelope's is k × ~13 × ~600): below it the ~2 µs of
#: :func:`~sail_env.physics.blas.one_blas_thread` would only slow a single environment's step.
THREADED_BATCH = 8


@dataclasses.dataclass
class PlantParams:
    """Per-environment arrays (leading axis k, or 1 when shared); a plant may add fields."""

    a: np.ndarray  # (·, n, n) system matrix
    b: np.ndarray  # (·, n, m) input matrix (m + 1 columns with a constant term, its input held at 1)
    step: np.ndarray  # (·, P·n, n + m) one control step: rows of [Φ Γ] for ε⁰ (and ε¹, ε², … with push noise)
    envelope: np.ndarray  # (·, S, R·(n + m)) look-ahead table of the lateral speed (pointing.envelope_table)
    acceleration: np.ndarray  # (·,) axial acceleration F/m [m/s²]
    limits: np.ndarray  # (·, 2) largest lateral offset [m] and tilt [rad] inside the beam and the small-angle regime
    growth: np.ndarray  # (·,) largest growth rate [1/s] of the state (with noise: of its spread, if faster)
    shared: bool

    def take(self, index: np.ndarray) -> PlantParams:
        """The parameters of environments ``index`` (shared parameters are returned as they are)."""
        if self.shared:
            return self
        return dataclasses.replace(self, shared=False, **{f.name: getattr(self, f.name)[index]
                                                          for f in dataclasses.fields(self) if f.name != "shared"})

    def repeat(self, count: int) -> PlantParams:
        """Each environment's parameters ``count`` times in a row (shared parameters as they are)."""
        if self.shared or count == 1:
            return self
        return dataclasses.replace(self, shared=False, **{f.name: np.repeat(getattr(self, f.name), count, axis=0)
                                                          for f in dataclasses.fields(self) if f.name != "shared"})

    def put(self, index: np.ndarray, other: PlantParams) -> None:
        """Overwrite environments ``index`` with ``other`` (both per-environment)."""
        for field in (f for f in dataclasses.fields(self) if f.name != "shared"):
            mine, theirs = getattr(self, field.name), getattr(other, field.name)
            if mine.shape[1:] != theirs.shape[1:]:  # envelope tables of another length
                width = max(mine.shape[1], theirs.shape[1])
                mine, theirs = _pad_rows(mine, width), _pad_rows(theirs, width)
                setattr(self, field.name, mine)
            mine[index] = theirs


def _pad_rows(table: np.ndarray, width: int) -> np.ndarray:
    """Repeat the last row of each (k, S, ·) table up to ``width`` rows (the maximum is unchanged)."""
    if table.shape[1] == width:
        return table
    return np.concatenate([table, np.repeat(table[:, -1:], width - table.shape[1], axis=1)], axis=1)


def _batch_threads(k: int) -> contextlib.AbstractContextManager:
    """One BLAS thread for a batch of ``k`` environments large enough to be threaded."""
    return one_blas_thread() if k >= THREADED_BATCH else contextlib.nullcontext()


class LinearPlant:
    """What every batched linear plant shares: the parameter draw, the exact step (with the push
    as a polynomial in its relative error), the envelope and the coast.

    A subclass sets :attr:`state_names`, :attr:`input_names`, :attr:`spread_fields`,
    :attr:`jitter_inputs` (the input columns a beam offset moves) and the units, and builds
    :class:`PlantParams` in ``_build``; it says when the sail has diverged and how fast it flies.
    The random disturbances (:mod:`sail_env.physics.disturbance`) reach the step and the coast
    through :meth:`jitter_std` (every active beam offset, added in variance) and
    :meth:`impact_rate_and_std` (at most one impulse process).
    """

    state_names: tuple[str, ...]
    state_units: tuple[str, ...]  # "m", "m/s", "rad", "rad/s": how the observation scales each state
    input_names: tuple[str, ...]
    input_units: tuple[str, ...]  # "m" and "rad" scale with the task's beam limits
    input_ranges: dict[str, float]  # the input at action +1 of any other unit
    spread_fields: tuple[str, ...]
    jitter_inputs: tuple[int, ...]
    velocity_rows: tuple[int, ...]  # the lateral velocity components (pointing and envelope)
    #: A constant term ``c`` in ``ds/dt = A s + B u + c``: the last column of ``B``, its input held at 1.
    biased = False
    #: Quantities a start may name but not change (the 3D sail's spin); none by default.
    fixed_state: Mapping[str, float] = MappingProxyType({})
    #: Pairs of state rows a start is limited in together (their length), as divergence limits them; none by default.
    radial_pairs: tuple[tuple[int, int], ...] = ()
    #: The divergence rule as data: the sail has left the beam or the small-angle regime when the
    #: Euclidean norm of a group's state rows (at most two) exceeds that group's column of
    #: ``PlantParams.limits`` (or is NaN). The compiled step and :meth:`diverged` both read it.
    divergence_groups: tuple[tuple[int, ...], ...]

    def __init__(self, nominal: LinearModel, dt: float, parameter_spread: float, push_noise: float,
                 disturbances: Sequence[Disturbance] = ()) -> None:
        self.nominal = nominal
        self.parameter_spread = parameter_spread
        self.push_noise = push_noise
        self.dt = dt
        self.disturbances = tuple(d for d in disturbances if d.active)
        self._beams = tuple(d for d in self.disturbances if d.channel == "beam")
        impulses = [d for d in self.disturbances if d.channel == "impulse"]
        if len(impulses) > 1:
            raise ValueError(f"at most one impulse disturbance can act (the step draws one kick size per row), "
                             f"got {[type(d).__name__ for d in impulses]}")
        self._impulse = impulses[0] if impulses else None
        #: State rows a random impact kicks (:meth:`impact_rate_and_std`); empty: no impacts.
        self.impulse_rows: tuple[int, ...] = self._impulse.rows(self) if self._impulse else ()
        # The beam offsets' intensity depends on the flight time (:meth:`jitter_std`); only the push's is constant.
        self.white_noise = WhiteNoise.from_step_std(0.0, push_noise, self.dt)
        self.noisy = bool(push_noise or self.disturbances)
        self._shared = None if parameter_spread else self._build(np.ones((1, self.n_factors)), shared=True)

    @property
    def n_states(self) -> int:
        return len(self.state_names)

    @property
    def n_inputs(self) -> int:
        return len(self.input_names)

    @property
    def n_factors(self) -> int:
        """Length of a row of parameter factors (:meth:`draw`, :meth:`params`)."""
        return len(self.spread_fields)

    @property
    def n_draws(self) -> int:
        """How many uniform numbers :meth:`draw` takes from a generator."""
        return self.n_factors if self.parameter_spread else 0

    # ------------------------------------------------------------------ parameters
    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """Per-episode factors of :attr:`spread_fields` (all one without spread; draws nothing then)."""
        return self.factors(rng.random((1, self.n_draws)))[0]

    def factors(self, uniforms: np.ndarray) -> np.ndarray:
        """The factors (k, n_factors) of uniform numbers in [0, 1) (k, :attr:`n_draws`): what
        :meth:`draw` makes of its generator's numbers, for a batch drawn one call per environment."""
        if not self.parameter_spread:
            return np.ones((len(uniforms), self.n_factors))
        low, high = 1 - self.parameter_spread, 1 + self.parameter_spread
        return low + (high - low) * uniforms

    def params(self, factors: np.ndarray) -> PlantParams:
        """Parameters for environments with the given factors (k, n_factors); shared without spread.
        Built with one BLAS thread (:mod:`sail_env.physics.blas`), as are :meth:`coast` and the batched
        :meth:`step` and :meth:`peak_speed` (shared parameters are built once: no threads to limit)."""
        if self._shared is not None:
            return self._shared
        with one_blas_thread():
            return self._build(factors, shared=False)

    def _build(self, factors: np.ndarray, shared: bool) -> PlantParams:
        raise NotImplementedError

    # ------------------------------------------------------------------ physics
    def with_bias(self, u: np.ndarray) -> np.ndarray:
        """The inputs ``u`` (k, m) with the constant term's input (1) appended when :attr:`biased`."""
        return np.concatenate([u, np.ones((len(u), 1))], axis=-1) if self.biased else u

    @property
    def constant_term(self) -> np.ndarray:
        """The nominal model's constant term ``c`` (n,) (zero unless :attr:`biased`)."""
        return np.zeros(self.n_states)

    def check_disturbances(self, disturbances: Sequence[Disturbance]) -> tuple[Disturbance, ...]:
        """Each active disturbance's check against this sail (a ``ValueError`` naming its keyword);
        the active ones. A subclass calls it once it knows its sail, before its costly tables."""
        active = tuple(d for d in disturbances if d.active)
        for disturbance in active:
            disturbance.check(self)
        return active

    def impact_rate_and_std(self, p: PlantParams, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean rate [1/s] (k,) of the random impacts at flight time ``t`` (k,) and the standard
        deviation (k, r) of one impact's kick on each of :attr:`impulse_rows` (SI rates)."""
        return self._impulse.rate_and_kick(self, p, t)

    def impacts_along(self, speed: object, xp: object = np) -> tuple[object, object]:
        """:meth:`impact_rate_and_std` at the sail's axial ``speed`` [m/s], in the array module ``xp``: the
        law the JAX backend reads along a flight."""
        return self._impulse.at_speed(self, speed, xp)

    def _impact_psd(self, p: PlantParams, t: np.ndarray) -> np.ndarray | None:
        """White-noise intensity (k, n, n) of the impacts at times ``t`` (k,): rate × a kick's mean
        square on :attr:`impulse_rows` (None without impacts)."""
        if not self.impulse_rows:
            return None
        rate, std = self.impact_rate_and_std(p, t)
        psd = np.zeros((len(t), self.n_states, self.n_states))
        rows = list(self.impulse_rows)
        psd[:, rows, rows] = rate[:, None] * std**2
        return psd

    def step(self, p: PlantParams, x: np.ndarray, u: np.ndarray, push: np.ndarray | None = None) -> np.ndarray:
        """One control step with ``u`` held; ``push`` (k,) is the relative push error ε of the step."""
        n = self.n_states
        z = np.concatenate([x, self.with_bias(u)], axis=-1)
        with _batch_threads(len(z)):
            y = z @ p.step[0].T if p.shared else np.matmul(p.step, z[:, :, None])[:, :, 0]
        if push is None:
            return y[:, :n]
        eps = push[:, None]
        out = y[:, -n:]
        for power in range(y.shape[1] // n - 2, -1, -1):  # Horner's scheme in ε
            out = y[:, power * n:(power + 1) * n] + eps * out
        return out

    def diverged(self, p: PlantParams, x: np.ndarray) -> np.ndarray:
        """Whether each sail (``x``: (k, n), or (k, …, n) of each environment's) has left the beam or the
        small-angle regime by :attr:`divergence_groups` (NaN counts as left)."""
        inside = np.ones(x.shape[:-1], dtype=bool)
        for column, rows in enumerate(self.divergence_groups):
            size = np.abs(x[..., rows[0]]) if len(rows) == 1 else np.hypot(x[..., rows[0]], x[..., rows[1]])
            inside &= size <= p.limits[:, column].reshape(-1, *[1] * (x.ndim - 2))
        return ~inside

    def start_limits(self) -> np.ndarray:
        """Largest size of each state component (n,) a start may have: inside the beam and the
        small-angle regime for every parameter draw, and not leaving them within one step."""
        raise NotImplementedError

    def peak_speed(self, p: PlantParams, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Largest lateral speed [m/s] the sail would reach with ``u`` held (the envelope)."""
        with _batch_threads(len(x)):
            return peak_speed(p.envelope[0] if p.shared else p.envelope, x, self.with_bias(u), len(self.velocity_rows))

    def coast_pieces(self, p: PlantParams, duration: np.ndarray) -> np.ndarray:
        """How many pieces :meth:`coast` splits each propagation into (one unless the sail is unstable)."""
        return np.maximum(1, np.ceil(duration * p.growth / GROWTH_PER_PIECE).astype(np.int64))

    def _push_terms(self, p: PlantParams) -> tuple[np.ndarray, np.ndarray]:
        """``(∂A/∂ln F, ∂B/∂ln F)`` of the draws ``p`` for the moment generator (each model supplies its own)."""
        raise NotImplementedError

    def _moment_terms(self, p: PlantParams, u: np.ndarray, t: np.ndarray) -> tuple:
        """The arguments of :func:`~sail_env.physics.noise.moment_generator` (and of
        :func:`~sail_env.physics.noise.moment_matrices`) for the models ``p`` with ``u`` held at flight
        time ``t`` (k,): the push noise, each beam offset as white noise of intensity ``σ² dt`` and
        the impacts of intensity rate × kick²."""
        std = self.jitter_std(p, t)
        psd = (std[:, 0] if np.ndim(std) else std) ** 2 * self.dt
        return (p.a, p.b, self.with_bias(u), self.white_noise, self._push_terms(p),
                self.jitter_inputs if self.jittered else (), psd, self._impact_psd(p, t))

    def _moment_generator(self, p: PlantParams, u: np.ndarray, t: np.ndarray) -> np.ndarray:
        """``d vec(M)/dt = G vec(M)`` of the second moments with ``u`` held at flight time ``t`` (k,)
        (:meth:`_moment_terms`)."""
        return moment_generator(*self._moment_terms(p, u, t))

    def held_input_generator(self, p: PlantParams, t: np.ndarray) -> np.ndarray:
        """:func:`~sail_env.physics.noise.held_input_generator` of the models ``p`` at flight time ``t``
        (k,): one moment generator for every held input (with a constant term, its input is the last
        held input, at 1). The JAX backend's noisy coast starts from it."""
        a, b, _, noise, push, jitter, psd, impacts = self._moment_terms(p, np.zeros((len(t), self.n_inputs)), t)
        return held_input_generator(a, b, noise, push, jitter, psd, impacts)

    def piece_propagators(self, p: PlantParams, u: np.ndarray, start_s: np.ndarray,
                          duration: np.ndarray) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The propagator of one :meth:`coast` piece of ``duration`` (k,) seconds from flight time
        ``start_s`` (k,) with ``u`` (k, m) held, as :meth:`coast` builds it: of the second moments
        (k, h, h) for a :attr:`noisy` plant, else ``(Φ, Γu)``. The JAX backend is handed its pre-control coast's."""
        return self._piece_propagators(p, u, (start_s + 0.5 * duration)[:, None], duration)[0]

    @property
    def jittered(self) -> bool:
        """Whether the beam's offset at the sail jitters (any active beam disturbance)."""
        return bool(self._beams)

    def jitter_std(self, p: PlantParams, t: np.ndarray) -> np.ndarray | float:
        """Standard deviation [m] of the beam's offset during a step at flight times ``t`` (k,) or
        a grid (k, s) of each environment's: the active beam disturbances added in variance; a float,
        or (k, 1) (a grid: (k, s, 1))."""
        if not self._beams:
            return 0.0
        std = functools.reduce(np.hypot, (d.std_m(self, p, t) for d in self._beams))
        return std[..., None] if np.ndim(std) else std

    def jitter_std_along(self, distance: object, xp: object = np) -> object:
        """:meth:`jitter_std` at the sail's ``distance`` [m] from the array (None where no beam disturbance
        reads it), in the array module ``xp``: the law the JAX backend reads along a flight."""
        if not self._beams:
            return 0.0
        return functools.reduce(xp.hypot, (d.std_along(distance, xp) for d in self._beams))

    def flight_model(self, p: PlantParams) -> object | None:
        """What a coast along the flight reads (the JAX backend's): None for a model that does not change
        along it; the 3D plant's ``FlightModel``."""
        return None

    def coast(self, p: PlantParams, x: np.ndarray, u: np.ndarray, duration: np.ndarray,
              normals: np.ndarray | None, start_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Propagate ``duration`` (k,) seconds from flight time ``start_s`` (k,) with ``u`` held and
        the disturbances as white noise.

        Without noise the step is exact. With it, the first two moments are exact
        (:mod:`sail_env.physics.noise`) and the end state is drawn from that Gaussian with
        ``normals`` (k, pieces, n). An unstable sail is propagated in
        :meth:`coast_pieces` pieces and checked after each; a plant whose model changes along
        the flight (:meth:`_coast_params`) holds each piece's model at the piece's middle.
        Returns ``(x, diverged)``.
        """
        return self.coast_with_paths(p, x, u, duration, normals, None, start_s)[:2]

    @single_threaded
    def coast_with_paths(self, p: PlantParams, x: np.ndarray, u: np.ndarray, duration: np.ndarray,
                         normals: np.ndarray | None, paths: np.ndarray | None,
                         start_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """:meth:`coast`, and with ``paths`` (k, K, pieces, n) of a noisy plant K further coasts of each
        environment from the same ``x``, drawn through the same pieces' propagators (so they cost the
        draws, not the exponentials): ``(x, diverged, path_x (k, K, n), path_diverged (k, K))``, the
        last two None without ``paths``. The first two are :meth:`coast`'s to the last bit."""
        pieces = self.coast_pieces(p, duration)
        piece = duration / pieces
        total = int(pieces.max())
        diverged = np.zeros(len(x), dtype=bool)
        path_x = path_lost = None
        if paths is not None:
            path_x, path_lost = np.repeat(x[:, None], paths.shape[1], axis=1), np.zeros(paths.shape[:2], dtype=bool)
        # One propagator serves every piece of a time-invariant model; a time-varying one's are
        # built a batch of pieces at a time (one call instead of one per piece).
        batch = max(1, COAST_BATCH // len(x)) if self.time_varying else total
        for first in range(0, total, batch):
            count = min(batch, total - first)
            offsets = first + 0.5 + np.arange(count if self.time_varying else 1)
            # A model whose growth along the flight outruns the pieces (sized by the window's growth,
            # :meth:`coast_pieces`) overflows a piece's exponential: that sail has left the beam, its
            # state inf or NaN (:meth:`diverged`), not a floating-point error.
            with np.errstate(over="ignore", invalid="ignore"):
                propagators = self._piece_propagators(p, u, start_s[:, None] + offsets * piece[:, None], piece)
            for j in range(count):
                propagator = propagators[j if self.time_varying else 0]
                active = (first + j < pieces) & ~diverged
                if self.noisy:
                    moved = self._sample_piece(propagator, x, active, normals[:, first + j])
                else:
                    phi, drive = propagator
                    with np.errstate(over="ignore", invalid="ignore"):
                        moved = np.einsum("...ij,...j->...i", phi, x) + drive
                x = np.where(active[:, None], moved, x)
                diverged |= active & self.diverged(p, x)
                if paths is not None:
                    live = (first + j < pieces)[:, None] & ~path_lost
                    path_x = self._sample_paths(propagator, path_x, live, paths[:, :, first + j])
                    path_lost |= live & self.diverged(p, path_x)
        return x, diverged, path_x, path_lost

    def _sample_piece(self, propagator: np.ndarray, x: np.ndarray, active: np.ndarray,
                      normals: np.ndarray) -> np.ndarray:
        """The states (k, n) after one noisy piece with second-moment propagators (k, h, h): drawn from
        the exact moments for the ``active`` rows, ``x`` elsewhere.

        Only the active rows are propagated: a sail caught diverging keeps the state it was caught
        at, and carried on it overflowed within a piece or two (its second moments grow as the
        square of the state). Where an active sail's moments overflow all the same (a model whose
        growth along the flight outruns the pieces, :meth:`coast_pieces`), its state is NaN: it
        has left the beam (:meth:`diverged`), and no eigensolver is handed an infinite covariance.
        """
        rows = np.flatnonzero(active)
        moved = x.copy()
        start = second_moment(x[rows], np.zeros((len(rows), self.n_states, self.n_states)))
        with np.errstate(over="ignore", invalid="ignore"):
            # matmul, not einsum: the same BLAS call per environment whatever the batch's size
            # and layout, so a batch plays the single environments' episodes to the last bit.
            moved[rows] = _drawn((propagator[rows] @ start[:, :, None])[:, :, 0], normals[rows])
        return moved

    def _sample_paths(self, propagator: np.ndarray, x: np.ndarray, active: np.ndarray,
                      normals: np.ndarray) -> np.ndarray:
        """:meth:`_sample_piece` of each environment's K paths (k, K, n) through its one propagator
        (k, h, h), ``active`` (k, K): one product of the paths' second moments with each propagator."""
        start = second_moment(x, np.zeros((*x.shape, self.n_states)))
        with np.errstate(over="ignore", invalid="ignore"):
            moved = _drawn(start @ np.swapaxes(propagator, -1, -2), normals)
        return np.where(active[..., None], moved, x)

    #: Whether :meth:`_coast_params` depends on the time (then each piece has its own model).
    time_varying = False

    def _coast_params(self, p: PlantParams, u: np.ndarray, t: np.ndarray) -> PlantParams:
        """The model at flight time ``t`` (k,) with ``u`` held (the same at every time unless
        :attr:`time_varying`)."""
        return p

    def _piece_propagators(self, p: PlantParams, u: np.ndarray, middles: np.ndarray,
                           piece: np.ndarray) -> list[np.ndarray | tuple[np.ndarray, np.ndarray]]:
        """The propagators of pieces of ``piece`` (k,) seconds with the model held at their
        ``middles`` (k, c) (the midpoint rule: second order in the piece's length), one per column:
        of the second moments (k, h, h) with noise, else ``(Φ, Γu)``."""
        k, count = middles.shape
        rows = np.repeat(np.arange(k), count)  # environment-major: row r is piece r % count of r // count
        q = self._coast_params(p.repeat(count), u[rows], middles.ravel())
        if self.noisy:
            generator = self._moment_generator(q, u[rows], middles.ravel())
            exp = moment_propagator(generator, piece[rows], self.start_limits())
            return list(np.swapaxes(exp.reshape(k, count, *exp.shape[1:]), 0, 1))
        if q.shared and np.all(piece == piece[0]) and not self.biased:
            phi, gamma = self.nominal.discretize(float(piece[0]))
            return [(phi, np.einsum("...ij,...j->...i", gamma, u))] * count
        phi, gamma = zoh_discretize(q.a, q.b, piece[rows])
        drive = np.einsum("...ij,...j->...i", gamma, self.with_bias(u)[rows])
        return [(phi.reshape(k, count, *phi.shape[1:])[:, j], drive.reshape(k, count, -1)[:, j]) for j in range(count)]


def _drawn(second: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """States (..., n) drawn with ``normals`` (..., n) from the Gaussians of second moments (..., h)
    (:func:`~sail_env.physics.noise.second_moment`); NaN where the moments overflowed."""
    mean, cov = mean_and_covariance(second)
    finite = np.isfinite(mean).all(axis=-1) & np.isfinite(cov).all(axis=(-2, -1))
    out = np.full(mean.shape, np.nan)
    out[finite] = sample_gaussian(mean[finite], cov[finite], normals[finite])
    return out
