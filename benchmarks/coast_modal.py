"""A cheaper coast piece for the 3D realistic tasks: the moments in the drift's eigenbasis, measured
against today's 45×45 exponential (issue 18's coast; docs/performance.md, docs/physics.md §14).

    python -m benchmarks.coast_modal [--task LightSail3DRealistic-v1] [--agents passive lqg]
                                     [--episodes 6] [--rounds 5] [--out PATH]

Today each ≤ 5 s coast piece propagates the second moments of the augmented state ``z = (s, 1)``
exactly, by the exponential of their 45×45 generator (:mod:`sail_env.physics.noise`), and draws the
piece's end state from the Gaussian with those moments. A piece starts from a point (the previous
draw), and within it the model is held: ``dz = ã z dt + m̃ z dW_F + jitter``, ``ã`` the drift with
the Itô correction, ``m̃`` the push noise's matrix (PSD ``S_F``), ``Q`` the additive intensities. In
the eigenbasis of the 9×9 drift, ``ã = V Λ V⁻¹``:

* the mean is ``V e^{Λh} V⁻¹ z₀`` (exact);
* the additive noise's covariance is ``V (Q̂ ∘ D) Vᵀ``, ``Q̂ = V⁻¹ Q V⁻ᵀ``, ``D_ik = ∫₀^h e^{(λᵢ+λₖ)r} dr``;
* the push noise's, driven by the noise-free path, is ``S_F V Ŷ Vᵀ`` with ``Ŷ_ik = Σ_jl F̂_ij F̂_kl Ẑ_jl
  J(λᵢ+λₖ, λⱼ+λₗ)``, ``F̂ = V⁻¹ m̃ V``, ``Ẑ = V⁻¹ z₀z₀ᵀ V⁻ᵀ`` and the divided difference
  ``J(ν, μ) = ∫₀^h e^{ν(h−r)} e^{μr} dr = (e^{μh} − e^{νh})/(μ − ν)`` (the Fréchet derivative of the
  exponential on a diagonalisable matrix, Daleckiĭ & Kreĭn 1965; Higham 2008, *Functions of
  Matrices*, Thm 3.11; a series where ``|μ − ν| h < 1e-3``).

What this leaves out is the push noise acting on any spread made within the piece, by itself or by
the beam jitter (``S_F m̃ P m̃ᵀ`` with ``P`` the piece's own covariance; the draw at the piece's end
carries it into the next piece). Its relative size is of order ``S_F ‖m̃‖² h``, linear in the push
PSD; one Richardson step in the piece's length removes its leading part: the piece as two halves
(the second from the first's Gaussian, whose spread then drives its push noise) against the whole,
``2 C_halves − C_whole``, with an error that falls as ``h²`` on short pieces and is still linear in
``S_F`` (a smaller constant). No 45×45 matrix, no
exponential but the nine ``e^{λh}``: one 9×9 eigensolve, two tables of divided differences between
the 45 pairs ``(i ≤ k)`` (for ``h`` and ``h/2``) and three sums over 45 × 45 pairs of pairs.

The script plays ``--episodes`` episodes of ``--task`` with each of ``--agents`` (seeds 100000, …),
records the plant's coasts (a wrapper around the instance's ``coast``: a measurement, not the
package's API) and reports:

* per piece, from the exact coast's own start points: the mean's error (in the state's start limits),
  the covariance's (``max |ΔC_ij| / (σᵢ σⱼ)``) for the one-piece form and with the Richardson step;
* per episode, the whole coast both ways with the same normals: the relative change of the terminal
  pointing and how many successes (≤ 10 nrad) change;
* the cost: a whole coast (propagators and draws) both ways, interleaved, best of ``--rounds``, thread
  CPU time, and the propagators alone (today's batched generators and exponentials against the
  modal pieces), BLAS on one thread as in the plant's coast. The modal pieces are a plain Numba
  function (it uses the sums' symmetry in ``(j, l)``, not the eigenvalues' conjugate pairs); the
  draws stay today's NumPy in both. A third workload, the whole modal coast compiled (pieces and
  draws in one Numba call; the pieces' matrices still built by the plant's NumPy), says what a
  compiled coast would cost; a fourth, the same with each piece's eigenbasis interpolated
  (:func:`interpolated_bases`: cubic splines through an eigensolve every 25 s) instead of solved,
  what the per-piece eigensolve costs. Its errors are reported beside the others' (per piece and
  whole coasts, kinks left out).

Episodes whose coast crosses a kink of the beam's widening (the plant splits those pieces) are left
out of the whole-coast comparison and counted.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np
import scipy.interpolate

import sail_env  # noqa: F401
from agents.evaluation import make_agent, run_episode
from sail_env.core.reward import succeeded
from sail_env.physics.blas import one_blas_thread
from sail_env.physics.linear import sample_gaussian
from sail_env.physics.noise import mean_and_covariance, moment_matrices, second_moment
from sail_env.provenance import machine

RESULTS = Path(__file__).parent / "results"
#: Below this ``|μ − ν| h`` the divided difference is summed as a series (error < 1e-14).
SERIES_BELOW = 1e-3
#: Eigensolves along the coast every this many seconds, the pieces' eigenbases interpolated between.
EIGEN_SPACING_S = 25.0
#: Above this bound on the eigenvectors' condition number the drift counts as defective (the plant's is ~1e3).
CONDITION_LIMIT = 1e8


@numba.njit(cache=True, error_model="numpy")
def _divided(nu: complex, mu: complex, e_nu: complex, e_mu: complex, h: float) -> complex:
    """``∫₀^h e^{ν(h−r)} e^{μr} dr`` from ``e^{νh}``, ``e^{μh}`` (symmetric in ``ν, μ``). The quotient
    inherits the exponentials' phase round-off, ~``ε |μh| / |x|`` relative (≤ 1e-10 for this task's
    pairs); ``h e^{νh} (e^x − 1)/x`` would avoid it at the cost of an exponential per entry."""
    x = (mu - nu) * h
    if abs(x) < SERIES_BELOW:
        return h * e_nu * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)))
    return (e_mu - e_nu) / (mu - nu)


@numba.njit(cache=True, error_model="numpy")
def _differences(lam, h):
    """The pairs ``(i ≤ k)``, their sums ``λᵢ + λₖ``, ``e^{(λᵢ+λₖ)h}``, the table of divided differences
    between every two pairs (symmetric) and each pair's against 0 (the additive noise's)."""
    size = len(lam)
    count = size * (size + 1) // 2
    first, second = np.empty(count, np.int64), np.empty(count, np.int64)
    sums, grow = np.empty(count, np.complex128), np.empty(count, np.complex128)
    rotate = np.exp(lam * h)
    p = 0
    for i in range(size):
        for k in range(i, size):
            first[p], second[p], sums[p], grow[p] = i, k, lam[i] + lam[k], rotate[i] * rotate[k]
            p += 1
    table = np.empty((count, count), np.complex128)
    alone = np.empty(count, np.complex128)
    for p in range(count):
        alone[p] = _divided(0j, sums[p], 1.0 + 0j, grow[p], h)
        for q in range(p, count):
            table[p, q] = table[q, p] = _divided(sums[p], sums[q], grow[p], grow[q], h)
    return first, second, rotate, table, alone


@numba.njit(cache=True, error_model="numpy")
def _moments(vec, inv, f_hat, q_hat, push_psd, differences, mean0, cov0):
    """Mean and covariance (augmented, 9 and 9×9) over the time of ``differences`` from a Gaussian
    ``(mean0, cov0)``, the push noise driven by the start's second moment carried without noise."""
    first, second, rotate, table, alone = differences
    count = len(first)
    z_hat = inv @ (np.outer(mean0, mean0) + cov0).astype(np.complex128) @ inv.T
    made = np.empty((len(rotate), len(rotate)), np.complex128)
    for p in range(count):
        i, k = first[p], second[p]
        push = 0j
        for q in range(count):  # (j, l) and (l, j) together: Ẑ and the table are symmetric in them
            j, l = first[q], second[q]
            weight = f_hat[i, j] * f_hat[k, l]
            if j != l:
                weight += f_hat[i, l] * f_hat[k, j]
            push += weight * z_hat[j, l] * table[p, q]
        made[i, k] = made[k, i] = q_hat[i, k] * alone[p] + push_psd * push
    flow = (vec * rotate) @ inv
    mean = (flow @ mean0.astype(np.complex128)).real
    cov = (flow @ cov0.astype(np.complex128) @ flow.T + vec @ made @ vec.T).real
    return mean, cov


@numba.njit(cache=True, error_model="numpy")
def modal_piece(drift, mult, additive, push_psd, h, start, richardson):
    """Mean (n,) and covariance (n, n) of a piece of ``h`` seconds from the point ``start`` (n,):
    ``drift``, ``mult`` and ``additive`` are the augmented (n+1)×(n+1) matrices of the docstring."""
    lam, vec = np.linalg.eig(drift.astype(np.complex128))
    inv = np.linalg.inv(vec)
    if np.abs(vec).max() * np.abs(inv).max() * len(lam) > CONDITION_LIMIT:
        # A defective drift (e.g. a free drift pushed by a constant force) has no eigenbasis.
        raise ValueError("the drift has no well-conditioned eigenbasis: the modal form does not apply")
    return modal_piece_in_basis(lam, vec, inv, mult, additive, push_psd, h, start, richardson)


@numba.njit(cache=True, error_model="numpy")
def modal_piece_in_basis(lam, vec, inv, mult, additive, push_psd, h, start, richardson):
    """:func:`modal_piece` with the drift's eigenvalues, eigenvectors and their inverse given."""
    f_hat = inv @ mult.astype(np.complex128) @ vec
    q_hat = inv @ additive.astype(np.complex128) @ inv.T
    size = len(lam)
    point = np.append(start, 1.0)
    still = np.zeros((size, size))
    mean, cov = _moments(vec, inv, f_hat, q_hat, push_psd, _differences(lam, h), point, still)
    if richardson:
        half = _differences(lam, 0.5 * h)
        half_mean, half_cov = _moments(vec, inv, f_hat, q_hat, push_psd, half, point, still)
        mean, halves = _moments(vec, inv, f_hat, q_hat, push_psd, half, half_mean, half_cov)
        cov = 2.0 * halves - cov
    n = size - 1
    return mean[:n].copy(), cov[:n, :n].copy()


@numba.njit(cache=True, error_model="numpy")
def _draw(mean, cov, normals):
    """:func:`~sail_env.physics.linear.sample_gaussian`'s draw, compiled, to time what a compiled coast
    would cost (its eigensolver is Numba's LAPACK, not NumPy's: the same draw to round-off)."""
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    safe = np.where(std > 0, std, 1.0)
    corr = cov / np.outer(safe, safe)
    values, vectors = np.linalg.eigh(0.5 * (corr + corr.T))
    root = (vectors * np.sqrt(np.maximum(values, 0.0))) @ vectors.T
    return mean + std * (root @ normals)


@numba.njit(cache=True, error_model="numpy")
def compiled_coast(drift, mult, additive, push_psd, h, start, normals):
    """A whole coast of modal pieces (with the Richardson step) and draws in one call: the end state.
    The plant's divergence test after each piece is left out (a few comparisons)."""
    x = start.copy()
    for j in range(len(drift)):
        mean, cov = modal_piece(drift[j], mult[j], additive[j], push_psd, h, x, True)
        x = _draw(mean, cov, normals[j])
    return x


@numba.njit(cache=True, error_model="numpy")
def compiled_coast_in_bases(lam, vec, inv, mult, additive, push_psd, h, start, normals):
    """:func:`compiled_coast` with each piece's eigenbasis given (:func:`interpolated_bases`)."""
    x = start.copy()
    for j in range(len(lam)):
        mean, cov = modal_piece_in_basis(lam[j], vec[j], inv[j], mult[j], additive[j], push_psd, h, x, True)
        x = _draw(mean, cov, normals[j])
    return x


def interpolated_bases(plant, coast: dict, spacing: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each piece's drift eigenvalues, eigenvectors and their inverse (count, n+1[, n+1]) from cubic
    splines through eigensolves every ~``spacing`` seconds of the coast (both ends included): the
    modes keep their order (by frequency, then decay) and each eigenvector its phase, fixed on the
    component that is largest at the coast's start, so that they vary smoothly between the nodes. A
    coast across a kink of the spot's widening is refused: the model jumps there."""
    if split_pieces(plant, coast).any():
        raise ValueError("the coast crosses a kink of the spot's widening: its eigenbases jump there")
    count, length, middles = pieces_of(plant, coast)
    start, end = float(coast["start_s"][0]), float(coast["start_s"][0] + coast["duration"][0])
    nodes = np.linspace(start, end, max(4, math.ceil((end - start) / spacing) + 1))
    lam, vec = np.linalg.eig(piece_matrices(plant, coast["p"], coast["u"], nodes)[0])
    order = np.argsort(lam.imag + 1e-9 * lam.real, axis=1)
    lam, vec = np.take_along_axis(lam, order, axis=1), np.take_along_axis(vec, order[:, None, :], axis=2)
    anchor = np.argmax(np.abs(vec[0]), axis=0)
    phase = vec[:, anchor, np.arange(vec.shape[2])]
    vec = vec / (phase / np.abs(phase))[:, None, :]
    lam_at = scipy.interpolate.CubicSpline(nodes, lam, axis=0)(middles)
    vec_at = scipy.interpolate.CubicSpline(nodes, vec, axis=0)(middles)
    return lam_at, vec_at, np.linalg.inv(vec_at)


def piece_matrices(plant, p, u: np.ndarray, middles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The augmented drift, push-noise matrix and additive intensities (c, n+1, n+1) of one
    environment's pieces held at ``middles`` (c,), from the same terms as the plant's moment generator."""
    count = len(middles)
    held = np.repeat(u, count, axis=0)
    q = plant._coast_params(p.repeat(count), held, middles)
    drift, mult, additive = moment_matrices(*plant._moment_terms(q, held, middles))
    return drift, mult, np.broadcast_to(additive, drift.shape)


def record_coasts(task: str, agents: list[str], episodes: int) -> tuple[object, list[dict]]:
    """The plant of ``task`` and the inputs of every coast its episodes ran (one environment each)."""
    env = gym.make(task)
    plant = env.unwrapped.core.spec.plant
    coasts, exact_coast = [], plant.coast

    def recording(p, x, u, duration, normals, start_s):
        coasts.append({"p": p, "x": x.copy(), "u": u.copy(), "duration": duration.copy(),
                       "normals": normals.copy(), "start_s": start_s.copy(), "agent": current[0]})
        return exact_coast(p, x, u, duration, normals, start_s)

    plant.coast = recording
    current = [""]
    for name in agents:
        agent, current[0] = make_agent(name, env), name
        for seed in range(100000, 100000 + episodes):
            run_episode(env, agent, seed)
    plant.coast = exact_coast
    return plant, coasts


def pieces_of(plant, coast: dict) -> tuple[int, float, np.ndarray]:
    """How many pieces the coast takes, their length and their middles."""
    count = int(plant.coast_pieces(coast["p"], coast["duration"])[0])
    length = float(coast["duration"][0]) / count
    return count, length, coast["start_s"][0] + (np.arange(count) + 0.5) * length


def exact_pieces(plant, coast: dict) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray]:
    """Today's coast step by step: each piece's exact (mean, covariance) from the previous draw, and
    the end state."""
    count, length, middles = pieces_of(plant, coast)
    propagators = plant._piece_propagators(coast["p"], coast["u"], middles[None], np.array([length]))
    x, moments = coast["x"], []
    for j in range(count):
        start = second_moment(x, np.zeros((1, plant.n_states, plant.n_states)))
        mean, cov = mean_and_covariance((propagators[j] @ start[:, :, None])[:, :, 0])
        moments.append((x[0], mean[0], cov[0]))
        x = sample_gaussian(mean, cov, coast["normals"][:, j])
    return moments, x[0]


def modal_coast(plant, coast: dict, richardson: bool = True, interpolated: bool = False) -> np.ndarray:
    """The same coast with modal pieces and the same normals (each piece's eigenbasis its own, or
    :func:`interpolated_bases`): the end state."""
    count, length, middles = pieces_of(plant, coast)
    drift, mult, additive = piece_matrices(plant, coast["p"], coast["u"], middles)
    bases = interpolated_bases(plant, coast, EIGEN_SPACING_S) if interpolated else None
    x = coast["x"][0]
    push_psd = plant.white_noise.push_psd_s
    for j in range(count):
        if interpolated:
            mean, cov = modal_piece_in_basis(*(b[j] for b in bases), mult[j], additive[j], push_psd, length, x, richardson)
        else:
            mean, cov = modal_piece(drift[j], mult[j], additive[j], push_psd, length, x, richardson)
        x = sample_gaussian(mean, cov, coast["normals"][0, j])
    return x


def split_pieces(plant, coast: dict) -> np.ndarray:
    """Which pieces of this coast the plant splits where the beam's widening has a kink (count,)."""
    count, length, middles = pieces_of(plant, coast)
    ratio = np.full(count, coast["p"].acceleration[0] / plant.nominal_acceleration)
    cuts = plant._kink_times(ratio, middles - 0.5 * length, middles + 0.5 * length)
    return np.zeros(count, bool) if cuts is None else np.any(np.stack(cuts) < middles + 0.5 * length, axis=0)


def piece_errors(plant, coast: dict) -> dict[str, float]:
    """The largest per-piece errors of the modal forms against the exact moments, with each piece's
    own eigenbasis and with :func:`interpolated_bases` (pieces the plant splits at a kink left out,
    and a coast with a kink not interpolated)."""
    _, length, middles = pieces_of(plant, coast)
    drift, mult, additive = piece_matrices(plant, coast["p"], coast["u"], middles)
    moments, _ = exact_pieces(plant, coast)
    units, push_psd = plant.start_limits(), plant.white_noise.push_psd_s
    split = split_pieces(plant, coast)
    bases = None if split.any() else interpolated_bases(plant, coast, EIGEN_SPACING_S)
    worst = {"mean": 0.0, "cov_one_piece": 0.0, "cov_richardson": 0.0}
    if bases is not None:
        worst.update(mean_interpolated=0.0, cov_interpolated=0.0)
    for j, (start, mean, cov) in enumerate(moments):
        if split[j]:
            continue
        scale = np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
        for key, richardson in (("cov_one_piece", False), ("cov_richardson", True)):
            m, c = modal_piece(drift[j], mult[j], additive[j], push_psd, length, start, richardson)
            worst[key] = max(worst[key], float(np.max(np.abs(c - cov) / scale)))
            worst["mean"] = max(worst["mean"], float(np.max(np.abs(m - mean) / units)))
        if bases is None:
            continue
        m, c = modal_piece_in_basis(*(b[j] for b in bases), mult[j], additive[j], push_psd, length, start, True)
        worst["cov_interpolated"] = max(worst["cov_interpolated"], float(np.max(np.abs(c - cov) / scale)))
        worst["mean_interpolated"] = max(worst["mean_interpolated"], float(np.max(np.abs(m - mean) / units)))
    return worst


def best_cpu(tasks: dict[str, callable], rounds: int) -> dict[str, float]:
    """Best thread CPU seconds of each task, taking turns, with BLAS on one thread (as the plant's
    coast runs it)."""
    best = dict.fromkeys(tasks, np.inf)
    with one_blas_thread():
        for _ in range(rounds):
            for name, task in tasks.items():
                start = time.thread_time()
                task()
                best[name] = min(best[name], time.thread_time() - start)
    return best


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="LightSail3DRealistic-v1")
    parser.add_argument("--agents", nargs="+", default=["passive", "lqg"])
    parser.add_argument("--episodes", type=int, default=6, help="episodes per agent")
    parser.add_argument("--rounds", type=int, default=5, help="turns of each timed workload (best counts)")
    parser.add_argument("--out", type=Path, default=RESULTS / "coast_modal.json")
    args = parser.parse_args(argv)

    plant, coasts = record_coasts(args.task, args.agents, args.episodes)
    rows = []
    for coast in coasts:
        count, length, _ = pieces_of(plant, coast)
        row = {"agent": coast["agent"], "pieces": count, "piece_s": length, **piece_errors(plant, coast)}
        if split_pieces(plant, coast).any():
            row["kink"] = True
        else:
            cutoff = coast["start_s"] + coast["duration"]
            _, exact_end = exact_pieces(plant, coast)
            exact = float(plant.pointing(coast["p"], exact_end[None], cutoff)[0])
            modal = float(plant.pointing(coast["p"], modal_coast(plant, coast)[None], cutoff)[0])
            interpolated = float(plant.pointing(coast["p"], modal_coast(plant, coast, interpolated=True)[None], cutoff)[0])
            row.update(pointing_rad=exact, modal_pointing_rad=modal, pointing_change=abs(modal / exact - 1),
                       success_changed=bool(succeeded(np.array(exact)) != succeeded(np.array(modal))),
                       interpolated_pointing_change=abs(interpolated / exact - 1),
                       interpolated_success_changed=bool(succeeded(np.array(exact)) != succeeded(np.array(interpolated))))
        rows.append(row)
        print({k: (f"{v:.3g}" if isinstance(v, float) else v) for k, v in row.items()}, flush=True)

    longest = max((c for c in coasts if not split_pieces(plant, c).any()), key=lambda c: pieces_of(plant, c)[0])
    count, length, middles = pieces_of(plant, longest)
    push_psd = plant.white_noise.push_psd_s

    def modal_propagators() -> None:
        drift, mult, additive = piece_matrices(plant, longest["p"], longest["u"], middles)
        for j in range(count):
            modal_piece(drift[j], mult[j], additive[j], push_psd, length, longest["x"][0], True)

    def whole_coast_compiled() -> np.ndarray:
        drift, mult, additive = piece_matrices(plant, longest["p"], longest["u"], middles)
        return compiled_coast(drift, mult, additive, push_psd, length, longest["x"][0], longest["normals"][0, :count])

    def whole_coast_compiled_interpolated() -> np.ndarray:
        _, mult, additive = piece_matrices(plant, longest["p"], longest["u"], middles)
        lam, vec, inv = interpolated_bases(plant, longest, EIGEN_SPACING_S)
        return compiled_coast_in_bases(lam, vec, inv, mult, additive, push_psd, length, longest["x"][0],
                                       longest["normals"][0, :count])

    compiled_change = np.max(np.abs(whole_coast_compiled() / modal_coast(plant, longest) - 1))
    interpolated_change = np.max(np.abs(whole_coast_compiled_interpolated() / modal_coast(plant, longest, interpolated=True) - 1))
    timed = {"exact_coast": lambda: plant.coast(longest["p"], longest["x"], longest["u"], longest["duration"],
                                                 longest["normals"], longest["start_s"]),
             "modal_coast": lambda: modal_coast(plant, longest),
             "compiled_modal_coast": whole_coast_compiled,
             "compiled_modal_coast_interpolated": whole_coast_compiled_interpolated,
             "exact_propagators": lambda: plant._piece_propagators(longest["p"], longest["u"], middles[None],
                                                                  np.array([length])),
             "modal_propagators": modal_propagators}
    cost = best_cpu(timed, args.rounds)
    whole = [r for r in rows if "pointing_change" in r]
    summary = {"pieces_compared": int(sum(r["pieces"] for r in rows)),
               "largest_mean_error": max(r["mean"] for r in rows),
               "largest_cov_error_one_piece": max(r["cov_one_piece"] for r in rows),
               "largest_cov_error_richardson": max(r["cov_richardson"] for r in rows),
               "coasts_compared_whole": len(whole), "coasts_with_kinks": len(rows) - len(whole),
               "median_pointing_change": float(np.median([r["pointing_change"] for r in whole])) if whole else None,
               "largest_pointing_change": max((r["pointing_change"] for r in whole), default=None),
               "successes_changed": sum(r["success_changed"] for r in whole),
               "timed_coast_pieces": count,
               "cpu_ms": {k: 1e3 * v for k, v in cost.items()},
               "coast_ratio": cost["exact_coast"] / cost["modal_coast"],
               "compiled_coast_ratio": cost["exact_coast"] / cost["compiled_modal_coast"],
               "compiled_end_state_change": float(compiled_change),
               "largest_mean_error_interpolated": max(r["mean_interpolated"] for r in whole),
               "largest_cov_error_interpolated": max(r["cov_interpolated"] for r in whole),
               "median_pointing_change_interpolated": float(np.median([r["interpolated_pointing_change"] for r in whole]))
               if whole else None,
               "largest_pointing_change_interpolated": max((r["interpolated_pointing_change"] for r in whole), default=None),
               "successes_changed_interpolated": sum(r["interpolated_success_changed"] for r in whole),
               "compiled_interpolated_coast_ratio": cost["exact_coast"] / cost["compiled_modal_coast_interpolated"],
               "compiled_interpolated_end_state_change": float(interpolated_change),
               "propagator_ratio": cost["exact_propagators"] / cost["modal_propagators"]}
    print(json.dumps(summary, indent=1))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"task": args.task, "agents": args.agents, "episodes": args.episodes,
                                    "machine": machine(), "summary": summary, "coasts": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
