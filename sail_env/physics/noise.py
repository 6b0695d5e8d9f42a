"""Exact first and second moments of a linear sail model driven by white noise.

Two disturbances act over the whole beam time:

* **beam pointing jitter**: white noise on the beam's landing offset ``d`` with
  two-sided power spectral density ``S_d`` [m² s] (additive: it enters
  through the first column of ``B``);
* **push fluctuation**: relative white noise ``ε`` on the push, ``F → F (1 + ε)``,
  PSD ``S_F`` [s]. Every force term scales with ``F``, so this noise multiplies the
  state: ``ds = (A s + B u) dt + (A_F s + B_F u) dW_F`` (Stratonovich, as befits
  physical noise of short correlation time).

For a linear system with additive and multiplicative white noise the second moment
``M = E[x xᵀ]`` of the augmented state ``x = (s, 1)`` obeys a *linear* ODE
(Itô form, with the Stratonovich drift correction ``½ S_F A_F²``)::

    dM/dt = Ã M + M Ãᵀ + S_F Ã_F M Ã_Fᵀ + S_d b bᵀ M[-1, -1]

For the planar model (:mod:`sail_env.physics.planar.model`) the correction vanishes (``Ã_F² = 0``: the
push scales forces that depend on positions only), so the two readings agree there; it matters for a
push-scaled force on a velocity.

so it is propagated exactly by one matrix exponential of the vectorised generator
(after Van Loan 1978, IEEE TAC 23:395, who treats the additive case). ``M`` is symmetric and
the equation keeps it so: only its ``(n+1)(n+2)/2`` entries on and above the diagonal are
propagated (the half-vectorisation ``vech``; Magnus & Neudecker 1980, SIAM J. Alg. Disc. Meth.
1:422, for the duplication and elimination matrices), which makes the exponential of the
8-state 3D model 45×45 instead of 81×81. The end state is then drawn from the Gaussian with
these moments: exact for additive noise, a Gaussian closure with exact mean and covariance for
the multiplicative part.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import numpy as np
import scipy.linalg

from sail_env.physics.linear import augmented


@dataclasses.dataclass(frozen=True)
class WhiteNoise:
    """Continuous-time white-noise intensities (two-sided PSDs).

    Attributes:
        beam_jitter_psd_m2s: PSD of the beam landing offset [m² s]. A per-step random
            offset of standard deviation σ held for ``dt`` has ``σ² dt``.
        push_psd_s: PSD of the relative push fluctuation [s]; per step ``σ_F² dt``.
    """

    beam_jitter_psd_m2s: float = 0.0
    push_psd_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("beam_jitter_psd_m2s", "push_psd_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")

    @classmethod
    def from_step_std(cls, jitter_std_m: float, push_std: float, dt: float) -> "WhiteNoise":
        """Intensities that match per-step noise of the given standard deviations."""
        return cls(jitter_std_m**2 * dt, push_std**2 * dt)


def moment_generator(a: np.ndarray, b: np.ndarray, action: np.ndarray, noise: WhiteNoise,
                     push: tuple[np.ndarray, np.ndarray], jitter_inputs: tuple[int, ...],
                     jitter_psd: np.ndarray | None = None, state_psd: np.ndarray | None = None,
                     xp: Any = np) -> np.ndarray:
    """The ``h × h`` matrix ``G_h`` with ``d vech(M)/dt = G_h vech(M)``, ``h = (n+1)(n+2)/2``
    (:func:`_vech_maps`): :func:`vec_moment_generator` (same arguments) on the symmetric second moments,
    ``G_h = L G D`` with the elimination ``L`` (its rows of ``vech``'s entries) and the duplication
    ``D`` (an off-diagonal entry stands for itself and its mirror, so their columns add).

    ``xp`` is the array module: ``jax.numpy`` builds the same generator under ``jit`` and ``vmap``
    (the JAX backend's coast of a model that changes along the flight), ``jitter_psd`` and
    ``state_psd`` may then be traced; ``noise`` (floats) and ``jitter_inputs`` are constants."""
    rows, cols, _ = _vech_maps(a.shape[-1] + 1)
    coefficients = _generator_rows(a, b, action, noise, push, jitter_inputs, jitter_psd, state_psd, rows, cols, xp)
    off_diagonal = rows != cols
    return _added(coefficients[..., rows, cols], np.s_[..., off_diagonal],
                  coefficients[..., cols[off_diagonal], rows[off_diagonal]])


def held_input_generator(a: np.ndarray, b: np.ndarray, noise: WhiteNoise, push: tuple[np.ndarray, np.ndarray],
                         jitter_inputs: tuple[int, ...], jitter_psd: np.ndarray | None = None,
                         state_psd: np.ndarray | None = None, held: int | None = None, xp: Any = np) -> np.ndarray:
    """:func:`moment_generator` of the state ``(s, u)`` whose input ``u`` (its first ``held`` columns of
    ``b``, all by default) is held as constant states: one generator per model for every held input
    (arguments as :func:`moment_generator`'s, without the action), of size ``(n+held+1)(n+held+2)/2``.
    Columns of ``b`` past ``held`` are inputs at 1 (a plant's constant term): they join the constant's
    column, so the constant needs no state of its own. :func:`held_input_maps` turns it into the
    generator of one input, so a backend that meets a new input at every episode's end (the JAX one)
    builds each model's once; its exponential over a piece moves the second moments of ``(s, u, 1)``
    for every held input at once (the JAX backend's fast coast). ``xp`` as :func:`moment_generator`'s."""
    n, m = b.shape[-2:]
    held = m if held is None else held
    b_held = _placed(xp.zeros((*b.shape[:-2], n + held, m), b.dtype), np.s_[..., :n, :], b)
    a_push, b_push = push
    held_push = (augmented(a_push, b_push[..., :held], xp), _placed(xp.zeros(b_held.shape, b.dtype), np.s_[..., :n, :], b_push))
    held_state_psd = None
    if state_psd is not None:
        held_state_psd = _placed(xp.zeros((*np.shape(state_psd)[:-2], n + held, n + held), a.dtype), np.s_[..., :n, :n],
                                 state_psd)
    at_one = np.concatenate([np.zeros(held), np.ones(m - held)]).astype(a.dtype)
    return moment_generator(augmented(a, b[..., :held], xp), b_held, at_one, noise, held_push, jitter_inputs,
                            jitter_psd, held_state_psd, xp=xp)


@functools.lru_cache(maxsize=None)
def held_input_maps(n: int, m: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(R, L0, L1, L2)`` with ``moment_generator(…, u, …) = R G L(u)`` for ``G`` the
    :func:`held_input_generator` and ``L(u) = L0 + Σ_j u_j L1[j] + Σ_ij u_i u_j L2[i, j]``.

    ``L(u)`` (h' × h) lifts the second moments of ``(s, 1)`` to those of ``(s, u, 1)`` when ``u`` is
    known: ``E[s u_j] = E[s] u_j``, ``E[u_i u_j] = u_i u_j``, ``E[u_i] = u_i``; ``R`` (h × h') picks the
    entries of ``(s, 1)`` back out. Exact: the lifted moments move with ``G`` and stay lifted. Read-only."""
    small, large = n + 1, n + m + 1
    rows_s, cols_s, _ = _vech_maps(small)
    rows_l, cols_l, _ = _vech_maps(large)
    _, _, position_s = _vech_maps(small)
    entry_s = position_s.reshape(small, small)
    constant = n + m  # the constant's index in (s, u, 1)

    def reduced(index: int) -> int | None:
        """The index in (s, 1) of an index of (s, u, 1); None for an input's."""
        return index if index < n else (n if index == constant else None)

    h_small, h_large = len(rows_s), len(rows_l)
    lift0, lift1 = np.zeros((h_large, h_small)), np.zeros((m, h_large, h_small))
    lift2 = np.zeros((m, m, h_large, h_small))
    pick = np.zeros((h_small, h_large))
    for k, (p, q) in enumerate(zip(rows_l, cols_l)):
        rp, rq = reduced(p), reduced(q)
        if rp is not None and rq is not None:
            lift0[k, entry_s[rp, rq]] = 1.0
            pick[entry_s[rp, rq], k] = 1.0
        elif rp is not None and rp < n:  # E[s_p u_j] = E[s_p] u_j
            lift1[q - n, k, entry_s[rp, n]] = 1.0
        elif rp is None and rq is None:  # E[u_i u_j]
            lift2[p - n, q - n, k, entry_s[n, n]] = 1.0
        else:  # E[u_i · 1]
            lift1[p - n, k, entry_s[n, n]] = 1.0
    for array in (pick, lift0, lift1, lift2):
        array.setflags(write=False)
    return pick, lift0, lift1, lift2


def vec_moment_generator(a: np.ndarray, b: np.ndarray, action: np.ndarray, noise: WhiteNoise,
                         push: tuple[np.ndarray, np.ndarray], jitter_inputs: tuple[int, ...],
                         jitter_psd: np.ndarray | None = None,
                         state_psd: np.ndarray | None = None) -> np.ndarray:
    """The ``(n+1)² × (n+1)²`` matrix ``G`` with ``d vec(M)/dt = G vec(M)`` (row-major ``vec``),
    batched over the leading axes of ``a`` (..., n, n), ``b`` (..., n, m) and ``action`` (..., m).

    ``push`` is ``(∂A/∂ln F, ∂B/∂ln F)``, which the model supplies; the beam jitter acts,
    independently and with the same PSD, on each input column in ``jitter_inputs``; ``jitter_psd``
    (batched like ``a``'s leading axes) replaces ``noise``'s beam-jitter PSD; ``state_psd`` (..., n, n)
    is white noise added to the state's derivative directly (its intensity matrix).
    """
    size = a.shape[-1] + 1
    rows, cols = np.divmod(np.arange(size * size), size)
    coefficients = _generator_rows(a, b, action, noise, push, jitter_inputs, jitter_psd, state_psd, rows, cols)
    return coefficients.reshape(*coefficients.shape[:-2], size * size)


def moment_matrices(a: np.ndarray, b: np.ndarray, action: np.ndarray, noise: WhiteNoise,
                    push: tuple[np.ndarray, np.ndarray], jitter_inputs: tuple[int, ...],
                    jitter_psd: np.ndarray | None = None, state_psd: np.ndarray | None = None,
                    xp: Any = np) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The augmented state's equation ``dz = Ã z dt + Ã_F z dW_F + dW`` (arguments as
    :func:`vec_moment_generator`, ``xp`` as :func:`moment_generator`'s): the Itô drift ``Ã`` (with
    ``½ S_F Ã_F²``) and the push noise's ``Ã_F``, both (*batch, n+1, n+1), and the additive intensity
    ``E[dW dWᵀ]/dt`` ((…, n+1, n+1), batched like ``b`` and ``jitter_psd``; zero in the constant's row
    and column)."""
    a_push, b_push = push
    batch = np.broadcast_shapes(a.shape[:-2], b.shape[:-2], np.shape(action)[:-1])
    n = a.shape[-1]
    drift = _placed(xp.zeros((*batch, n + 1, n + 1), a.dtype), np.s_[..., :n, :n], a)
    drift = _placed(drift, np.s_[..., :n, n], xp.einsum("...ij,...j->...i", b, action))
    mult = _placed(xp.zeros((*batch, n + 1, n + 1), a.dtype), np.s_[..., :n, :n], a_push)
    mult = _placed(mult, np.s_[..., :n, n], xp.einsum("...ij,...j->...i", b_push, action))
    drift = drift + 0.5 * noise.push_psd_s * mult @ mult
    psd = noise.beam_jitter_psd_m2s if jitter_psd is None else xp.asarray(jitter_psd)[..., None, None]
    jitter_b = xp.zeros((*b.shape[:-2], n + 1, b.shape[-1]), b.dtype)  # the constant row feels no jitter
    jitter_b = _placed(jitter_b, np.s_[..., :n, :], b)
    additive = sum(psd * jitter_b[..., :, None, column] * jitter_b[..., None, :, column] for column in jitter_inputs)
    if state_psd is not None:
        additive = additive + _placed(xp.zeros((*np.shape(state_psd)[:-2], n + 1, n + 1), a.dtype), np.s_[..., :n, :n],
                                      state_psd)
    return drift, mult, xp.broadcast_to(additive, (*np.shape(additive)[:-2], n + 1, n + 1))


def _generator_rows(a: np.ndarray, b: np.ndarray, action: np.ndarray, noise: WhiteNoise,
                    push: tuple[np.ndarray, np.ndarray], jitter_inputs: tuple[int, ...],
                    jitter_psd: np.ndarray | None, state_psd: np.ndarray | None, rows: np.ndarray,
                    cols: np.ndarray, xp: Any = np) -> np.ndarray:
    """``dM_ij/dt`` for the entries ``(rows, cols)`` (r,) as coefficients of ``M`` (..., r, n+1, n+1):
    ``Σ_k Ã_ik M_kj + Σ_l Ã_jl M_il + S_F Σ_kl Ã_F,ik Ã_F,jl M_kl + (S_d b bᵀ + S_state)_ij M_nn`` (the rows
    of the vec generator; arguments as :func:`vec_moment_generator`, ``xp`` as :func:`moment_generator`'s)."""
    drift, mult, additive = moment_matrices(a, b, action, noise, push, jitter_inputs, jitter_psd, state_psd, xp)
    batch, n = drift.shape[:-2], a.shape[-1]
    drift, mult = drift.reshape(-1, n + 1, n + 1), mult.reshape(-1, n + 1, n + 1)
    # C order, the entries of a row together: ``take``, as fancy indexing would lay NumPy's product out
    # rows first, and a generator of another layout need not meet the same BLAS kernels downstream.
    out = noise.push_psd_s * xp.take(mult, rows, axis=1)[..., None] * xp.take(mult, cols, axis=1)[:, :, None, :]
    entry = np.arange(len(rows))
    out = _added(out, np.s_[:, entry, :, cols], xp.swapaxes(drift[:, rows, :], 0, 1))  # Ã M: M_kj for row (i, j)
    out = _added(out, np.s_[:, entry, rows, :], drift[:, cols, :])  # M Ãᵀ: M_il
    out = _added(out, np.s_[:, :, n, n],
                 xp.broadcast_to(additive[..., rows, cols], (*batch, len(rows))).reshape(-1, len(rows)))
    return out.reshape(*batch, len(rows), n + 1, n + 1)


def _placed(array: np.ndarray, index: Any, values: np.ndarray) -> np.ndarray:
    """``array`` with ``values`` written at ``index``: in place for a NumPy array, a new array for a
    JAX one (immutable: ``.at[].set``). One code path for both array modules, and NumPy's as cheap as
    a plain assignment (a copy per update makes the generators of 118 3D models a quarter slower)."""
    if isinstance(array, np.ndarray):
        array[index] = values
        return array
    return array.at[index].set(values)


def _added(array: np.ndarray, index: Any, values: np.ndarray) -> np.ndarray:
    """``array`` with ``values`` added at ``index``, as :func:`_placed` writes; the entries must be
    distinct (NumPy's ``+=`` adds a repeated entry's values once, JAX's ``.add`` every one)."""
    if isinstance(array, np.ndarray):
        array[index] += values
        return array
    return array.at[index].add(values)


def moment_propagator(generator: np.ndarray, duration: np.ndarray, units: np.ndarray) -> np.ndarray:
    """``expm(G_h duration)`` of vech generators (..., h, h) (``duration`` batched like their leading
    axes), taken with the states in ``units`` (n,) rounded to powers of two, so that the change of
    units is exact. In SI units the generator mixes entries of 1e-2 rad with 1e2 m/s, and its
    exponential over the planar coast (65,000 rad of phase) keeps the tilt's variance only to ~2e-8
    of its second moment; in the states' own scales to ~5e-11 (a diagonal balancing, as LAPACK's
    ``gebal`` does for eigenvalues; scipy's ``expm`` does not balance)."""
    into, back = balancing(units)
    return scipy.linalg.expm(generator * (np.asarray(duration)[..., None, None] * into)) * back


def balancing(units: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The factors ``(into, back)`` (h, h) of :func:`moment_propagator`'s change of units:
    ``expm(G_h t) = expm(G_h t · into) · back`` (elementwise), the states in ``units`` (n,) rounded to
    powers of two (exact)."""
    scale = np.append(2.0 ** np.round(np.log2(units)), 1.0)
    rows, cols, _ = _vech_maps(len(scale))
    weight = scale[rows] * scale[cols]  # vech(M) in the new units is vech(M) / weight
    return weight / weight[:, None], weight[:, None] / weight


def moment_growth_rate(a: np.ndarray, b: np.ndarray, noise: WhiteNoise,
                       push: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Growth rate [1/s] of the state's spread under the noise, batched like ``a`` (..., n, n): half
    the largest real part of the moment generator's eigenvalues (``push`` as in
    :func:`vec_moment_generator`; the beam jitter and the input only drive the moments). Multiplicative
    push noise makes the second moment grow even where the noise-free sail only oscillates (parametric
    excitation), so a long noisy propagation must be split by this rate, not the noise-free one."""
    generator = moment_generator(a, b, np.zeros((*a.shape[:-2], b.shape[-1])), noise, push, ())
    return 0.5 * np.linalg.eigvals(generator).real.max(axis=-1)


@functools.lru_cache(maxsize=None)
def _vech_maps(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The half-vectorisation of ``size × size`` symmetric matrices: the rows and columns of the
    entries on and above the diagonal, in ``vech`` order (row-major), and the ``vech`` position of
    every entry of the row-major ``vec`` (``vec = vech[position]``). Read-only, built once per size."""
    rows, cols = np.triu_indices(size)
    square = np.empty((size, size), dtype=np.int64)
    square[rows, cols] = square[cols, rows] = np.arange(len(rows))
    position = square.ravel()
    for array in (rows, cols, position):
        array.setflags(write=False)
    return rows, cols, position


def second_moment(mean: np.ndarray, cov: np.ndarray, xp: Any = np) -> np.ndarray:
    """``vech E[x xᵀ]`` of the augmented state ``x = (s, 1)`` (..., (n + 1)(n + 2)/2); ``xp`` is the
    array module (``jax.numpy`` for the JAX backend)."""
    n = mean.shape[-1]
    column = mean[..., :, None]
    top = xp.concatenate([cov + column * mean[..., None, :], column], axis=-1)
    bottom = xp.concatenate([mean, xp.ones_like(mean[..., :1])], axis=-1)[..., None, :]
    rows, cols, _ = _vech_maps(n + 1)
    return xp.concatenate([top, bottom], axis=-2)[..., rows, cols]


def mean_and_covariance(second: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`second_moment` (the covariance exactly symmetric: each pair is one entry)."""
    size = round((np.sqrt(8 * second.shape[-1] + 1) - 1) / 2)
    n = size - 1
    _, _, position = _vech_maps(size)
    full = second[..., position].reshape(*second.shape[:-1], size, size)
    mean = full[..., :n, n]
    return mean, full[..., :n, :n] - mean[..., :, None] * mean[..., None, :]
