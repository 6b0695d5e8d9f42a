"""Fewer coast pieces: a step taken relative to the middle's exact exponential (the interaction
picture), against the midpoint rule (today's coast), both against DOP853 of the linear time-varying model.

    python -m benchmarks.coast_interaction [--start 11] [--task LightSail3DRealistic-v1]
                                           [--out benchmarks/results/coast_interaction.json]

Over the coast the generator of the augmented state ``z = (s, 1)`` is ``G(t) = K + σ(t) R`` (the
kinematics, and the radiation's stiffness and push scaled by the Doppler power factor, ``σ`` its
ratio to the window's; :mod:`benchmarks.coast_pieces`). The midpoint rule holds ``σ`` at each
piece's middle; a fourth-order Magnus step in this frame diverges (a 1 s piece turns the fast mode
by 110 rad). Here each piece ``[t_m − h/2, t_m + h/2]`` is split as

    Φ = e^{G_m h/2} U e^{G_m h/2},   U = T exp ∫ e^{−G_m τ} δσ(τ) R e^{G_m τ} dτ,   δσ = σ(t_m + τ) − σ(t_m),

and ``U`` is close to one because ``δσ`` is small: its Magnus series converges on pieces of
minutes. In the eigenbasis of ``G_m = V Λ V⁻¹`` the first term is closed form,

    Ω̂₁ = R̂ ∘ W,   R̂ = V⁻¹ R V,   W_ij = ∫ δσ(τ) e^{(λⱼ−λᵢ)τ} dτ,

with the change of the generator over the piece a cubic (matrix) polynomial in ``τ``, fitted at
four Chebyshev points of the piece, and the moments ``∫ τⁿ e^{δτ} dτ`` by a series (``|δ| h/2 < 1``)
or the recurrence ``Iₙ = [τⁿ e^{δτ}/δ] − (n/δ) Iₙ₋₁``. ``U ≈ e^{Ω̂₁}`` ("interaction"). Its error
is still second order in ``h``: the second Magnus term ``½∬_{τ₁>τ₂} [Ã(τ₁), Ã(τ₂)]`` has a secular
part that does not average out over the fast phases, each mode's eigenvalue at second order in
``δσ``, ``δσ² Σ_k R̂_ik R̂_ki / (λᵢ − λₖ)`` (Rayleigh–Schrödinger perturbation theory, with left and
right eigenvectors for a non-normal matrix; Kato 1995, *Perturbation Theory for Linear Operators*,
Ch. II). "interaction2" adds it, integrated over the piece, over the modes ``k`` that turn against
``i`` by more than a radian within half a piece; on every slowly turning pair ``(i, j)``, not only
the diagonal, as ``½ Σ_k ∫ a_ik a_kj e^{(λⱼ−λᵢ)τ} dτ [1/(λᵢ−λₖ) + 1/(λⱼ−λₖ)]`` (:func:`secular`,
``a = V⁻¹ δG V``): the mean's model couples its near-degenerate pairs (3–7e-3 rad/s apart) by
nothing (``R̂_ik R̂_ki`` ~ 1e-17), but the second moments' equation does. The rest of the second
term oscillates and is left out; its next part,
``(a_ki a′_ik − a_ik a′_ki)/ω²``, cancels when the change is one matrix times a scalar (``δG = δσ R``,
the mean's model) but not for a general matrix polynomial (the covariance part's drift).

Three measurements (``benchmarks/results/coast_interaction.json``; docs/physics.md §14):

* **The mean** over the whole coast (``--start`` to cut-off at 600 s) from a typical state and
  command of the realistic sail (deep dish, spin, relativistic push, no diffraction), the model of
  :mod:`benchmarks.coast_pieces`: the augmented state's error at the end, each component in the
  plant's start limits, relative to the reference's size. The reference is DOP853 at ``rtol``
  1e-12; the same at 1e-11 bounds its own error.
* **The covariance**, on the coast to cut-off of LQG's second episode (seed 100001) of ``--task``:
  from the coast's start point, at its start and at its middle, the moments over 5, 20 and 50 s
  against DOP853 of the mean and covariance themselves (:meth:`MomentEquation.reference`; the moment
  equation's exponentials composed in 0.25 s pieces are a check of it), for today's 5 s pieces, the
  45×45 exponential held at the piece's middle, and the first candidate: the interaction picture's
  mean and the modal covariance of :mod:`benchmarks.coast_modal` (with its Richardson step) at the
  middle's model. Which part of the held model costs what: the same composition of the full (81×81)
  second-moment generator with only the drift, only the beam jitter's intensity, or both varying
  over the piece (the rest held at its middle), and with all varying (a check of the plant's own
  45×45 composition).
* **The second moments' equation stepped by the interaction picture** (:class:`MomentEquation`):
  the same step on ``d vec(M)/dt = G(t) vec(M)`` (81×81), relative to the middle's generator (its
  eigensolve) or to :func:`clustered_base` (the drift's Kronecker sum with the noise kept within
  slowly turning clusters, no eigensolve of the whole generator), with the second-order term of
  :func:`secular` on every slowly turning pair: per piece as above, and over the whole coast from
  its start point in ~20, 50 and 100 s steps against the exponentials in 0.0625 and 0.125 s pieces
  with one Richardson step; and what one piece costs in NumPy (not the method's cost).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import scipy.integrate
import scipy.linalg
import scipy.sparse.csgraph

from benchmarks.coast_modal import modal_piece, piece_matrices, record_coasts
from benchmarks.coast_pieces import U, X0, coast_model
from sail_env.physics.blas import one_blas_thread
from sail_env.physics.noise import mean_and_covariance, second_moment

RESULTS = Path(__file__).parent / "results"
END_S = 600.0
#: Below this ``|δ| h/2`` the moments ``∫ τⁿ e^{δτ} dτ`` are summed as a series.
SERIES_BELOW = 1.0
SERIES_TERMS = 30


def moments(delta: np.ndarray, half: float, degree: int) -> np.ndarray:
    """``∫_{−half}^{half} τⁿ e^{δτ} dτ`` for ``n = 0 … degree`` (degree+1, *delta.shape)."""
    delta = np.asarray(delta, complex)
    out = np.empty((degree + 1, *delta.shape), complex)
    small = np.abs(delta) * half < SERIES_BELOW
    # Series: Σ_m δ^m/m! ∫ τ^{n+m}, only the even powers n+m survive the symmetric span.
    d = np.where(small, delta, 0.0)
    for n in range(degree + 1):
        total = np.zeros(delta.shape, complex)
        term = np.ones(delta.shape, complex)  # δ^m / m!
        for m in range(SERIES_TERMS):
            if (n + m) % 2 == 0:
                total += term * 2.0 * half ** (n + m + 1) / (n + m + 1)
            term = term * d / (m + 1)
        out[n] = total
    # Recurrence: I_n = [τⁿ e^{δτ}/δ] − (n/δ) I_{n−1}, stable while |δ| half ≥ 1 and n small.
    big = np.where(small, 1.0, delta)
    plus, minus = np.exp(big * half), np.exp(-big * half)
    previous = (plus - minus) / big
    recurred = [previous]
    for n in range(1, degree + 1):
        previous = (half ** n * plus - (-half) ** n * minus) / big - n / big * previous
        recurred.append(previous)
    return np.where(small, out, np.array(recurred))


class Coast:
    """The realistic sail's coast model: ``G(t) = K + σ(t) R`` (augmented, 9×9)."""

    def __init__(self) -> None:
        plant, a_rad, b, self.window = coast_model()
        self.flight = plant.flight
        self.kinematics = np.zeros((9, 9))
        self.kinematics[:8, :8] = plant.kinematics
        self.radiation = np.zeros((9, 9))
        self.radiation[:8, :8] = a_rad
        self.radiation[:8, 8] = b @ U
        self.scale = np.append(plant.start_limits(), 1.0)

    def sigma(self, t: np.ndarray | float) -> np.ndarray:
        return np.asarray(self.flight.power_factor(t)) / self.window

    def generator(self, t: float) -> np.ndarray:
        return self.kinematics + float(self.sigma(t)) * self.radiation

    def reference(self, start: float, rtol: float) -> np.ndarray:
        def rhs(t: float, z: np.ndarray) -> np.ndarray:
            return self.generator(t) @ z
        return scipy.integrate.solve_ivp(rhs, (start, END_S), np.append(X0, 1.0), method="DOP853",
                                         rtol=rtol, atol=1e-16).y[:, -1]

    def midpoint(self, start: float, piece: float) -> np.ndarray:
        count = math.ceil((END_S - start) / piece - 1e-9)
        h = (END_S - start) / count
        z = np.append(X0, 1.0)
        for i in range(count):
            z = scipy.linalg.expm(h * self.generator(start + (i + 0.5) * h)) @ z
        return z

    def interaction(self, start: float, piece: float, second_order: bool) -> np.ndarray:
        count = math.ceil((END_S - start) / piece - 1e-9)
        h = (END_S - start) / count
        z = np.append(X0, 1.0)
        for i in range(count):
            middle = start + (i + 0.5) * h
            z = interaction_step(self.generator(middle), change_of(self.generator, middle, h), h, second_order) @ z
        return z


def interaction_step(middle: np.ndarray, change: np.ndarray, h: float, second_order: bool) -> np.ndarray:
    """The propagator of a piece of ``h`` seconds whose generator is ``middle + Σₙ change[n] τⁿ``
    (``τ`` from the piece's middle, ``change[0] ≈ 0``), in the interaction picture of ``middle``
    (the docstring's ``δσ R``, with a matrix for each power); ``middle`` must have an eigenbasis."""
    lam, vec = np.linalg.eig(middle)
    return step_in_basis(lam, vec, np.linalg.inv(vec), change, h, second_order)


def step_in_basis(lam: np.ndarray, vec: np.ndarray, inv: np.ndarray, change: np.ndarray, h: float,
                  second_order: bool) -> np.ndarray:
    """:func:`interaction_step` in the interaction picture of the base ``vec diag(lam) inv`` (any
    diagonalisable matrix; ``change`` is the generator minus that base)."""
    half = 0.5 * h
    gaps = lam[None, :] - lam[:, None]  # λ_j − λ_i
    degree = len(change) - 1
    c_hat = inv @ change @ vec  # (degree+1, n, n)
    omega = np.einsum("nij,nij->ij", c_hat, moments(gaps, half, degree))
    if second_order:
        omega += secular(lam, c_hat, half)
    turn = np.exp(lam * half)
    return ((vec * turn) @ scipy.linalg.expm(omega) @ (turn[:, None] * inv)).real


def clustered_base(generator: np.ndarray, drift: np.ndarray, half: float) -> tuple[np.ndarray, ...]:
    """A base for the second moments' equation without its eigensolve: in the eigenbasis ``V ⊗ V`` of
    the drift's Kronecker sum (eigenvalues ``λᵢ + λₖ``), the ``generator`` (81×81, vec) kept only
    within clusters of modes that turn slowly against each other (``|Δ| half ≤ 1``, linked), each
    cluster diagonalised alone (the largest has 17 modes; the rest, the push noise between clusters,
    is fast and left to the step). Returns the base's eigenvalues, eigenvectors, their inverse and
    the base itself (real)."""
    lam9, vec9 = np.linalg.eig(drift)
    inv9 = np.linalg.inv(vec9)
    kron_vec, kron_inv = np.kron(vec9, vec9), np.kron(inv9, inv9)
    sums = np.add.outer(lam9, lam9).ravel()
    hat = kron_inv @ generator @ kron_vec
    slow = np.abs(sums[None, :] - sums[:, None]) * half <= 1.0
    count, labels = scipy.sparse.csgraph.connected_components(slow, directed=False)
    lam = np.empty(len(sums), complex)
    within, vec, inv = (np.zeros_like(hat) for _ in range(3))
    for cluster in range(count):
        block = np.ix_(labels == cluster, labels == cluster)
        within[block] = hat[block]
        lam[labels == cluster], vec[block] = np.linalg.eig(hat[block])
        inv[block] = np.linalg.inv(vec[block])
    return lam, kron_vec @ vec, inv @ kron_inv, (kron_vec @ within @ kron_inv).real


def secular(lam: np.ndarray, c_hat: np.ndarray, half: float) -> np.ndarray:
    """The second Magnus term's part that the fast phases do not average out, on every slowly turning
    pair ``(i, j)`` (``|λⱼ − λᵢ| h/2 ≤ 1``, the diagonal among them), over the modes ``k`` that turn fast
    against both: ``½ Σ_k ∫ a_ik a_kj e^{(λⱼ−λᵢ)τ} dτ [1/(λᵢ − λₖ) + 1/(λⱼ − λₖ)]``, ``a = Σₙ c_hat[n] τⁿ``
    the change in the eigenbasis (on the diagonal, each mode's eigenvalue at second order)."""
    gaps = lam[None, :] - lam[:, None]  # λ_j − λ_i
    fast = np.abs(gaps) * half > 1.0
    inverse = np.where(fast, 1.0 / np.where(fast, -gaps, 1.0), 0.0)  # [i, k]: 1/(λ_i − λ_k)
    weight = fast[:, :, None] * fast.T[None, :, :] * (inverse[:, :, None] + inverse.T[None, :, :])  # [i, k, j]
    degree = len(c_hat) - 1
    powers = moments(gaps, half, 2 * degree)
    total = np.zeros(gaps.shape, complex)
    for n in range(degree + 1):
        for m in range(degree + 1):
            total += powers[n + m] * np.einsum("ik,kj,ikj->ij", c_hat[n], c_hat[m], weight)
    return np.where(fast, 0.0, 0.5 * total)


def change_of(generator, middle: float, h: float, degree: int = 3, base: np.ndarray | None = None) -> np.ndarray:
    """``generator(middle + τ) − base`` (by default ``generator(middle)``) as a matrix polynomial in
    ``τ`` (degree+1, n, n), fitted at ``degree + 1`` Chebyshev points of the piece."""
    nodes = 0.5 * h * np.cos(np.pi * (np.arange(degree + 1) + 0.5) / (degree + 1))
    values = np.array([generator(middle + tau) for tau in nodes]) - (generator(middle) if base is None else base)
    flat = np.polynomial.polynomial.polyfit(nodes, values.reshape(degree + 1, -1), degree)
    return flat.reshape(degree + 1, *values.shape[1:])


def mean_rows(start: float) -> tuple[float, list[dict]]:
    """The mean over the coast from ``start`` by each method and piece length: the reference's own
    error (two tolerances) and one row per (method, piece)."""
    coast = Coast()
    started = time.perf_counter()
    reference = coast.reference(start, 1e-12)
    size = np.linalg.norm(reference / coast.scale)

    def error(z: np.ndarray) -> float:
        return float(np.linalg.norm((z - reference) / coast.scale) / size)

    check = error(coast.reference(start, 1e-11))
    print(f"mean: DOP853 {start:.0f}-{END_S:.0f} s, {time.perf_counter() - started:.0f} s; rtol 1e-11 against 1e-12: "
          f"{check:.1e}", flush=True)
    rows = []
    for method in ("midpoint", "interaction", "interaction2"):
        for piece in (1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0):
            if method == "midpoint" and piece > 20:
                continue
            z = coast.midpoint(start, piece) if method == "midpoint" else \
                coast.interaction(start, piece, second_order=method == "interaction2")
            rows.append({"method": method, "piece_s": piece, "pieces": math.ceil((END_S - start) / piece - 1e-9),
                         "error": error(z)})
            print(f"  {method:12s} pieces of {piece:4.0f} s ({rows[-1]['pieces']:3d}): {rows[-1]['error']:.2e}", flush=True)
    return check, rows


def covariance_rows(task: str) -> tuple[list[dict], dict]:
    """Long pieces with noise, on LQG's coast to cut-off in ``task`` (seed 100001): from the coast's start
    point, at its start and its middle, the moments over 5, 20 and 50 s against
    :meth:`MomentEquation.reference` (the plant's exponentials composed in 0.25 s pieces a check of
    it), for today's 5 s pieces, the 45×45 exponential held at the piece's middle, the first
    candidate (the interaction picture's mean, the modal covariance of :mod:`benchmarks.coast_modal`
    at the middle's model), the parts of the held model varied one by one, and the moment equation's
    interaction steps; then :func:`whole_coast_rows`. Errors: the mean in units of the reference's
    spread, the covariance ``max |ΔC_ij| / (σᵢ σⱼ)``."""
    plant, coasts = record_coasts(task, ["lqg"], 2)  # seed 100000's episode ends before cut-off
    coast = max(coasts, key=lambda c: float(c["duration"][0]))  # the coast to cut-off, not a reset's
    p, u, x = coast["p"], coast["u"], coast["x"]
    first, duration = float(coast["start_s"][0]), float(coast["duration"][0])

    def composed(begin: float, h: float, piece: float) -> tuple[np.ndarray, np.ndarray]:
        count = int(round(h / piece))
        middles = begin + (np.arange(count) + 0.5) * piece
        moment = second_moment(x, np.zeros((1, plant.n_states, plant.n_states)))
        for propagator in plant._piece_propagators(p, u, middles[None], np.array([piece])):
            moment = (propagator @ moment[:, :, None])[:, :, 0]
        mean, cov = mean_and_covariance(moment)
        return mean[0], cov[0]

    push_psd = plant.white_noise.push_psd_s
    moments_of = MomentEquation(plant, p, u, x)

    def drift(t: float) -> np.ndarray:
        return moments_of.model(t)[0]

    def partly_held(begin: float, h: float, varying: tuple[str, ...], piece: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
        """The moments composed in ``piece`` s steps of the full (81×81) second-moment generator,
        each of "drift", "mult" (the push noise's matrix) and "additive" varying over the piece if
        named, else held at its middle (the drift's Itô term always from the ``mult`` used)."""
        count = int(round(h / piece))
        varied = piece_matrices(plant, p, u, begin + (np.arange(count) + 0.5) * piece)
        held = [m[0] for m in piece_matrices(plant, p, u, np.array([begin + 0.5 * h]))]
        moment = np.outer(np.append(x[0], 1.0), np.append(x[0], 1.0)).ravel()
        for j in range(count):
            drift_j, mult_j, additive_j = ((v[j] if name in varying else c) for name, v, c in
                                           zip(("drift", "mult", "additive"), varied, held))
            drift_j = drift_j + 0.5 * push_psd * (mult_j @ mult_j - (varied[1][j] if "drift" in varying else held[1])
                                                  @ (varied[1][j] if "drift" in varying else held[1]))
            moment = scipy.linalg.expm(piece * vec_generator(drift_j, mult_j, additive_j, push_psd)) @ moment
        return mean_and_covariance_of(moment)

    rows = []
    for offset in (0.0, 0.5 * duration):
        begin = first + offset
        for h in (5.0, 20.0, 50.0):
            mean, cov = moments_of.reference(begin, h)
            spread = np.sqrt(np.diag(cov))

            def errors(m: np.ndarray, c: np.ndarray) -> list[float]:
                return [float(np.max(np.abs(m - mean) / spread)), float(np.max(np.abs(c - cov) / np.outer(spread, spread)))]

            middle = begin + 0.5 * h
            held, mult, additive = piece_matrices(plant, p, u, np.array([middle]))
            step = interaction_step(held[0], change_of(drift, middle, h), h, second_order=True)
            candidate = (step @ np.append(x[0], 1.0))[:-1], modal_piece(
                held[0], mult[0], additive[0], plant.white_noise.push_psd_s, h, x[0], True)[1]
            row = {"from_s": offset, "piece_s": h, "composed_0.25": errors(*composed(begin, h, 0.25)),
                   "today": errors(*composed(begin, h, 5.0)), "held_exponential": errors(*composed(begin, h, h)),
                   "candidate": errors(*candidate),
                   "moment_full_base": errors(*moments_of.stepped(begin, h, 1, clustered=False)),
                   "moment_clustered": errors(*moments_of.stepped(begin, h, 1, clustered=True)),
                   "full_generator_check": errors(*partly_held(begin, h, ("drift", "mult", "additive"))),
                   "only_drift_varying": errors(*partly_held(begin, h, ("drift",))),
                   "only_jitter_varying": errors(*partly_held(begin, h, ("additive",))),
                   "drift_and_jitter_varying": errors(*partly_held(begin, h, ("drift", "additive")))}
            rows.append(row)
            print(f"  from {offset:5.0f} s, {h:3.0f} s: mean/σ, cov " + "; ".join(
                f"{key} {values[0]:.1e}, {values[1]:.1e}" for key, values in row.items() if isinstance(values, list)),
                flush=True)
    return rows, whole_coast_rows(plant, moments_of, first, duration, composed)


def mean_and_covariance_of(moment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The state's mean and covariance from the augmented second moments' ``vec`` (row-major)."""
    size = math.isqrt(len(moment))
    second = moment.reshape(size, size)
    mean = second[:-1, -1]
    return mean, second[:-1, :-1] - np.outer(mean, mean)


def vec_generator(drift: np.ndarray, mult: np.ndarray, additive: np.ndarray, push_psd: float) -> np.ndarray:
    """``G`` of ``d vec(M)/dt = G vec(M)`` (row-major ``vec``, 81×81) for ``dz = Ã z dt + Ã_F z dW_F + dW``:
    the drift on both sides, the push noise ``S_F Ã_F ⊗ Ã_F`` and the additive intensity times the
    constant's ``M_nn = 1``."""
    ones = np.eye(len(drift))
    out = np.kron(drift, ones) + np.kron(ones, drift) + push_psd * np.kron(mult, mult)
    out[:, -1] += additive.ravel()
    return out


class MomentEquation:
    """The second moments' equation of one recorded coast (81×81, vec, SI units), its interaction
    step, and a reference that does not go through ``M``.

    The step is taken in SI units. Balanced as the plant's exponentials are (the states' start limits
    rounded to powers of two), the 45×45 vech form's propagator agreed with the unbalanced one to
    ~1e-12 of its size, yet its covariance over a 5 s piece from the coast's start point was off by
    1.1e-3 against 1e-5: such a piece makes a covariance ~1e-8 of ``M``, and ``C = M − m mᵀ``
    magnifies the propagator's round-off (measured once, 2026-12-04; which entries carry it was not
    traced). A compiled step should carry ``C`` and ``m mᵀ`` apart."""

    def __init__(self, plant, p, u: np.ndarray, x: np.ndarray) -> None:
        self.plant, self.p, self.u, self.x = plant, p, u, x
        self.push_psd = plant.white_noise.push_psd_s

    def model(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The drift, push-noise matrix and additive intensity (9×9) at ``t``."""
        drift, mult, additive = piece_matrices(self.plant, self.p, self.u, np.array([t]))
        return drift[0], mult[0], additive[0]

    def generator(self, t: float) -> np.ndarray:
        return vec_generator(*self.model(t), self.push_psd)

    def reference(self, begin: float, h: float) -> tuple[np.ndarray, np.ndarray]:
        """The mean and covariance after ``h`` s from the coast's start point by DOP853 (rtol 1e-11) of
        ``dm/dt = Ã m``, ``dC/dt = ÃC + CÃᵀ + S_F Ã_F (C + m mᵀ) Ã_Fᵀ + Q`` (the model read at each time),
        which carries ``C`` itself: no cancellation against ``m mᵀ``."""
        size = self.plant.n_states + 1

        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            drift, mult, additive = self.model(t)
            mean, cov = y[:size], y[size:].reshape(size, size)
            change = drift @ cov + cov @ drift.T + self.push_psd * mult @ (cov + np.outer(mean, mean)) @ mult.T + additive
            return np.concatenate([drift @ mean, change.ravel()])

        start = np.concatenate([np.append(self.x[0], 1.0), np.zeros(size * size)])
        end = scipy.integrate.solve_ivp(rhs, (begin, begin + h), start, method="DOP853", rtol=1e-11, atol=1e-30).y[:, -1]
        return end[:size - 1], end[size:].reshape(size, size)[:-1, :-1]

    def step(self, begin: float, h: float, clustered: bool) -> np.ndarray:
        """One piece's propagator: in the interaction picture of the middle's generator (its 81×81
        eigensolve), or of :func:`clustered_base`."""
        middle = begin + 0.5 * h
        if not clustered:
            return interaction_step(self.generator(middle), change_of(self.generator, middle, h), h, second_order=True)
        lam, vec, inv, base = clustered_base(self.generator(middle), self.model(middle)[0], 0.5 * h)
        return step_in_basis(lam, vec, inv, change_of(self.generator, middle, h, base=base), h, second_order=True)

    def stepped(self, begin: float, span: float, count: int, clustered: bool) -> tuple[np.ndarray, np.ndarray]:
        """The mean and covariance after ``span`` s in ``count`` steps from the coast's start point."""
        start = np.append(self.x[0], 1.0)
        moment = np.outer(start, start).ravel()
        h = span / count
        for i in range(count):
            moment = self.step(begin + i * h, h, clustered) @ moment
        return mean_and_covariance_of(moment)


def whole_coast_rows(plant, moments_of: MomentEquation, first: float, duration: float, composed) -> dict:
    """The whole coast's end moments from its start point, no draw in between (the draws keep the
    first two moments, so today's coast has these): today's pieces and the clustered interaction
    steps of ~20, 50 and 100 s (and the middle's eigensolve at ~50 s) against the exponentials
    composed in ~0.0625 and ~0.125 s pieces with one Richardson step (the midpoint rule's error is
    even in the piece's length; the same from ~0.125 and ~0.25 s bounds the reference's own error).
    The coast must not cross a kink of the spot's widening, where the steps would need a cut. Then
    what one piece of each costs in NumPy and SciPy (thread CPU time, interleaved, best of 7): not the
    method's cost, which a compiled step with the symmetric 45-entry form would set."""
    ratio = np.atleast_1d(moments_of.p.acceleration / plant.nominal_acceleration)
    if plant._kink_times(ratio, np.array([first]), np.array([first + duration])) is not None:
        raise ValueError("the recorded coast crosses a kink of the spot's widening: choose another episode")

    def extrapolated(piece: float) -> tuple[np.ndarray, np.ndarray]:
        fine, coarse = (composed(first, duration, duration / round(duration / length)) for length in (piece, 2 * piece))
        return tuple((4.0 * a - b) / 3.0 for a, b in zip(fine, coarse))

    mean, cov = extrapolated(0.0625)
    spread = np.sqrt(np.diag(cov))

    def errors(m: np.ndarray, c: np.ndarray) -> list[float]:
        return [float(np.max(np.abs(m - mean) / spread)), float(np.max(np.abs(c - cov) / np.outer(spread, spread)))]

    today = int(plant.coast_pieces(moments_of.p, np.array([duration]))[0])
    out = {"duration_s": duration, "reference_check": errors(*extrapolated(0.125)),
           "today": {"pieces": today, "errors": errors(*composed(first, duration, duration / today))},
           "clustered": [], "full_base": {}}
    for piece in (20.0, 50.0, 100.0):
        count = math.ceil(duration / piece)
        out["clustered"].append({"pieces": count, "errors": errors(*moments_of.stepped(first, duration, count, True))})
    count = math.ceil(duration / 50.0)
    out["full_base"] = {"pieces": count, "errors": errors(*moments_of.stepped(first, duration, count, False))}
    print(f"  whole coast ({duration:.0f} s): reference check {out['reference_check']}, today ({today}) "
          f"{out['today']['errors']}; clustered " + "; ".join(f"{r['pieces']} steps {r['errors']}" for r in out["clustered"])
          + f"; full base {out['full_base']}", flush=True)
    h = duration / count
    middle = np.array([[first + 0.5 * h]])
    runs = {"today_piece": lambda: plant._piece_propagators(moments_of.p, moments_of.u, middle, np.array([h])),
            "clustered_piece": lambda: moments_of.step(first, h, True),
            "full_base_piece": lambda: moments_of.step(first, h, False)}
    timings = {key: [] for key in runs}
    with one_blas_thread():
        for _ in range(7):
            for key, run in runs.items():
                started = time.thread_time()
                run()
                timings[key].append(time.thread_time() - started)
    out["numpy_cpu_ms"] = {key: 1e3 * min(values) for key, values in timings.items()}
    print(f"  one piece in NumPy, CPU ms: {out['numpy_cpu_ms']}", flush=True)
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--start", type=float, default=11.0, help="where the mean's coast starts [s] (default: after the window)")
    parser.add_argument("--task", default="LightSail3DRealistic-v1", help="the task whose coast the covariance part takes")
    parser.add_argument("--out", type=Path, default=RESULTS / "coast_interaction.json")
    args = parser.parse_args(argv)
    check, rows = mean_rows(args.start)
    print(f"covariance: {args.task}", flush=True)
    covariance, whole = covariance_rows(args.task)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"start_s": args.start, "end_s": END_S, "reference_check": check, "mean": rows,
                                    "task": args.task, "covariance": covariance,
                                    "whole_coast": whole}, indent=1) + "\n")


if __name__ == "__main__":
    main()
