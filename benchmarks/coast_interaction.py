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
Ch. II). "interaction2" adds it to the diagonal of ``Ω̂₁``, integrated as ``∫ δσ² dτ``, over the
modes ``k`` that turn against ``i`` by more than a radian within half a piece. The near-degenerate
pairs, 3–7e-3 rad/s apart, are left to ``Ω̂₁``: ``R`` couples them by nothing here (``R̂_ik R̂_ki``
~ 1e-17). A model that coupled them would need the term on each slowly turning block,
``½ Σ_k ∫ a_ik a_kj e^{(λⱼ−λᵢ)τ} dτ [1/(λᵢ−λₖ) + 1/(λⱼ−λₖ)]`` over the fast ``k`` (``a = V⁻¹ δG V``),
not only on the diagonal. The rest of the second term oscillates and is left out; its next part,
``(a_ki a′_ik − a_ik a′_ki)/ω²``, cancels when the change is one matrix times a scalar (``δG = δσ R``,
the mean's model) but not for a general matrix polynomial (the covariance part's drift).

Two measurements (``benchmarks/results/coast_interaction.json``; docs/physics.md §14):

* **The mean** over the whole coast (``--start`` to cut-off at 600 s) from a typical state and
  command of the realistic sail (deep dish, spin, relativistic push, no diffraction), the model of
  :mod:`benchmarks.coast_pieces`: the augmented state's error at the end, each component in the
  plant's start limits, relative to the reference's size. The reference is DOP853 at ``rtol``
  1e-12; the same at 1e-11 bounds its own error.
* **The covariance**, on the coast to cut-off of LQG's second episode (seed 100001) of ``--task``:
  from the coast's start point, at its start and at its middle, the moments over 5, 20 and 50 s
  against the moment equation's exponentials composed in 0.25 s pieces (0.5 s pieces bound the
  reference's error), for
  today's 5 s pieces, the 45×45 exponential held at the piece's middle, and the candidate: the
  interaction picture's mean and the modal covariance of :mod:`benchmarks.coast_modal` (with its
  Richardson step) at the middle's model. The candidate's covariance holds the noise's model at the
  middle of the piece; how it fares over long pieces is what this measures. Which part of the held
  model costs what: the same composition of the full (81×81) second-moment generator with only the
  drift, only the beam jitter's intensity, or both varying over the piece (the rest held at its
  middle), and with all varying (against the plant's own 45×45 composition: a check of that code).
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

from benchmarks.coast_modal import modal_piece, piece_matrices, record_coasts
from benchmarks.coast_pieces import U, X0, coast_model
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
    half = 0.5 * h
    lam, vec = np.linalg.eig(middle)
    inv = np.linalg.inv(vec)
    gaps = lam[None, :] - lam[:, None]  # λ_j − λ_i
    degree = len(change) - 1
    c_hat = inv @ change @ vec  # (degree+1, n, n)
    omega = np.einsum("nij,nij->ij", c_hat, moments(gaps, half, degree))
    if second_order:
        # ∫ δĜ_ik(τ) δĜ_ki(τ) dτ over the powers' products, divided by λ_i − λ_k for the fast pairs.
        powers = moments(np.zeros(1), half, 2 * degree)[:, 0].real
        span = np.add.outer(np.arange(degree + 1), np.arange(degree + 1))
        product = np.einsum("nm,nik,mki->ik", powers[span], c_hat, c_hat)
        fast = np.abs(gaps) * half > 1.0
        omega[np.diag_indices(len(lam))] += np.where(fast, product / np.where(fast, -gaps, 1.0), 0.0).sum(axis=1)
    turn = np.exp(lam * half)
    return ((vec * turn) @ scipy.linalg.expm(omega) @ (turn[:, None] * inv)).real


def change_of(generator, middle: float, h: float, degree: int = 3) -> np.ndarray:
    """``generator(middle + τ) − generator(middle)`` as a matrix polynomial in ``τ`` (degree+1, n, n),
    fitted at ``degree + 1`` Chebyshev points of the piece."""
    nodes = 0.5 * h * np.cos(np.pi * (np.arange(degree + 1) + 0.5) / (degree + 1))
    values = np.array([generator(middle + tau) for tau in nodes]) - generator(middle)
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


def covariance_rows(task: str) -> list[dict]:
    """Long pieces with noise, on LQG's coast to cut-off in ``task`` (seed 100001): from the coast's start
    point, at its start and its middle, the moments over 5, 20 and 50 s against the moment equation's
    exponentials in 0.25 s pieces (0.5 s pieces give the reference's own error), for today's 5 s
    pieces, the 45×45 exponential held at the piece's middle, and the candidate (the interaction
    picture's mean, the modal covariance of :mod:`benchmarks.coast_modal` at the middle's model).
    Errors: the mean in units of the reference's spread, the covariance ``max |ΔC_ij| / (σᵢ σⱼ)``."""
    plant, coasts = record_coasts(task, ["lqg"], 2)  # seed 100000's episode ends before cut-off
    coast = max(coasts, key=lambda c: float(c["duration"][0]))  # the coast to cut-off, not a reset's
    p, u, x = coast["p"], coast["u"], coast["x"]
    first, duration = float(coast["start_s"][0]), float(coast["duration"][0])

    def drift(t: float) -> np.ndarray:
        return piece_matrices(plant, p, u, np.array([t]))[0][0]

    def composed(begin: float, h: float, piece: float) -> tuple[np.ndarray, np.ndarray]:
        count = int(round(h / piece))
        middles = begin + (np.arange(count) + 0.5) * piece
        moment = second_moment(x, np.zeros((1, plant.n_states, plant.n_states)))
        for propagator in plant._piece_propagators(p, u, middles[None], np.array([piece])):
            moment = (propagator @ moment[:, :, None])[:, :, 0]
        mean, cov = mean_and_covariance(moment)
        return mean[0], cov[0]

    push_psd, size = plant.white_noise.push_psd_s, plant.n_states + 1

    def partly_held(begin: float, h: float, varying: tuple[str, ...], piece: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
        """The moments composed in ``piece`` s steps of the full (81×81) second-moment generator,
        each of "drift", "mult" (the push noise's matrix) and "additive" varying over the piece if
        named, else held at its middle (the drift's Itô term always from the ``mult`` used)."""
        count = int(round(h / piece))
        varied = piece_matrices(plant, p, u, begin + (np.arange(count) + 0.5) * piece)
        held = [m[0] for m in piece_matrices(plant, p, u, np.array([begin + 0.5 * h]))]
        ones = np.eye(size)
        moment = np.outer(np.append(x[0], 1.0), np.append(x[0], 1.0)).ravel()
        for j in range(count):
            drift_j, mult_j, additive_j = ((v[j] if name in varying else c) for name, v, c in
                                           zip(("drift", "mult", "additive"), varied, held))
            drift_j = drift_j + 0.5 * push_psd * (mult_j @ mult_j - (varied[1][j] if "drift" in varying else held[1])
                                                  @ (varied[1][j] if "drift" in varying else held[1]))
            generator = np.kron(drift_j, ones) + np.kron(ones, drift_j) + push_psd * np.kron(mult_j, mult_j)
            generator[:, -1] += additive_j.ravel()  # the intensity times the constant's M_nn = 1
            moment = scipy.linalg.expm(piece * generator) @ moment
        moment = moment.reshape(size, size)
        mean = moment[:-1, -1]
        return mean, moment[:-1, :-1] - np.outer(mean, mean)

    rows = []
    for offset in (0.0, 0.5 * duration):
        begin = first + offset
        for h in (5.0, 20.0, 50.0):
            mean, cov = composed(begin, h, 0.25)
            spread = np.sqrt(np.diag(cov))

            def errors(m: np.ndarray, c: np.ndarray) -> list[float]:
                return [float(np.max(np.abs(m - mean) / spread)), float(np.max(np.abs(c - cov) / np.outer(spread, spread)))]

            middle = begin + 0.5 * h
            held, mult, additive = piece_matrices(plant, p, u, np.array([middle]))
            step = interaction_step(held[0], change_of(drift, middle, h), h, second_order=True)
            candidate = (step @ np.append(x[0], 1.0))[:-1], modal_piece(
                held[0], mult[0], additive[0], plant.white_noise.push_psd_s, h, x[0], True)[1]
            row = {"from_s": offset, "piece_s": h, "reference_check": errors(*composed(begin, h, 0.5)),
                   "today": errors(*composed(begin, h, 5.0)), "held_exponential": errors(*composed(begin, h, h)),
                   "candidate": errors(*candidate),
                   "full_generator_check": errors(*partly_held(begin, h, ("drift", "mult", "additive"))),
                   "only_drift_varying": errors(*partly_held(begin, h, ("drift",))),
                   "only_jitter_varying": errors(*partly_held(begin, h, ("additive",))),
                   "drift_and_jitter_varying": errors(*partly_held(begin, h, ("drift", "additive")))}
            rows.append(row)
            print(f"  from {offset:5.0f} s, {h:3.0f} s: mean/σ, cov " + "; ".join(
                f"{key} {values[0]:.1e}, {values[1]:.1e}" for key, values in row.items() if isinstance(values, list)),
                flush=True)
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--start", type=float, default=11.0, help="where the mean's coast starts [s] (default: after the window)")
    parser.add_argument("--task", default="LightSail3DRealistic-v1", help="the task whose coast the covariance part takes")
    parser.add_argument("--out", type=Path, default=RESULTS / "coast_interaction.json")
    args = parser.parse_args(argv)
    check, rows = mean_rows(args.start)
    print(f"covariance: {args.task}", flush=True)
    covariance = covariance_rows(args.task)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"start_s": args.start, "end_s": END_S, "reference_check": check, "mean": rows,
                                    "task": args.task, "covariance": covariance}, indent=1) + "\n")


if __name__ == "__main__":
    main()
