"""Batched linear algebra for linear sail models: every array may lead with a batch axis.

* :func:`zoh_discretize`: the exact zero-order-hold step of ``ẋ = A x + B u``.
* :func:`push_expansion`: the same step when the push is scaled by ``1 + ε``, as a
  polynomial in ``ε`` whose coefficients are computed once (for the per-step push noise).
* :func:`sample_gaussian`: draws from ``N(mean, cov)`` that stay correct when the
  covariance is huge, badly scaled or singular, and do not depend on the eigensolver
  (:func:`symmetric_root`); :func:`sample_uniform`.
* :class:`LinearModel`: one time-invariant ``ẋ = A x + B u`` with its cached exact steps and
  controllable subspace (the planar and the 3D models both are one).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
import scipy.linalg

#: Durations whose exact step :meth:`LinearModel.discretize` keeps.
DISCRETIZE_CACHE_SIZE = 4


class LinearModel:
    """``ds/dt = A s + B u`` (read-only matrices) and what controllers and the coast ask of it.

    ``push_sensitivity`` is ``(∂A/∂ln F, ∂B/∂ln F)``, how the matrices change with the push.
    """

    def __init__(self, a: np.ndarray, b: np.ndarray,
                 push_sensitivity: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self.A, self.B = a, b
        if push_sensitivity is not None:
            self.push_sensitivity = push_sensitivity
        self.A.setflags(write=False)
        self.B.setflags(write=False)
        self._discretized: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    @functools.cached_property
    def controllable_basis(self) -> np.ndarray:
        """Orthonormal basis (columns) of the controllable subspace ``range[B, AB, …, Aⁿ⁻¹B]``.

        Each block is scaled to unit norm (the same span): with ``‖A‖`` ~ 5e4 the block of
        ``A⁷B`` would otherwise bury a weak but real channel of the 3D model (a torque 200 times
        weaker than the force) below the rank threshold.
        """
        blocks = [self.B]
        for _ in range(self.A.shape[0] - 1):
            block = self.A @ blocks[-1]
            norm = np.linalg.norm(block)
            blocks.append(block / norm if norm > 0 else block)
        ctrb = np.hstack(blocks)
        u, sv, _ = np.linalg.svd(ctrb)
        rank = int(np.sum(sv > 1e-10 * sv[0])) if sv[0] > 0 else 0
        return u[:, :rank]

    @property
    def is_controllable(self) -> bool:
        return self.controllable_basis.shape[1] == self.A.shape[0]

    def discretize(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact zero-order-hold step ``s⁺ = Φ s + Γ u`` over ``dt`` seconds (read-only arrays).

        ``[[Φ, Γ], [0, I]] = expm([[A, B], [0, 0]] dt)`` (the augmented exponential). The
        last few durations are cached: the coast to a fixed cut-off repeats every episode,
        and its exponential (~40,000 rad of phase) costs milliseconds.
        """
        cached = self._discretized.pop(dt, None)
        if cached is None:
            cached = zoh_discretize(self.A, self.B, dt)
            for matrix in cached:
                matrix.setflags(write=False)
            if len(self._discretized) >= DISCRETIZE_CACHE_SIZE:
                del self._discretized[next(iter(self._discretized))]
        self._discretized[dt] = cached  # (re)inserted last: the dict is kept in recency order
        return cached


def augmented(a: np.ndarray, b: np.ndarray, xp: Any = np) -> np.ndarray:
    """``[[A, B], [0, 0]]``: the generator of ``(x, u)`` with ``u`` held (``xp``: the array module)."""
    n, m = b.shape[-2:]
    if xp is np:
        out = np.zeros((*a.shape[:-2], n + m, n + m))
        out[..., :n, :n] = a
        out[..., :n, n:] = b
        return out
    top = xp.concatenate([xp.broadcast_to(a, (*b.shape[:-2], n, n)), b], axis=-1)
    return xp.concatenate([top, xp.zeros((*top.shape[:-2], m, n + m), top.dtype)], axis=-2)


def zoh_discretize(a: np.ndarray, b: np.ndarray, dt: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact step ``x⁺ = Φ x + Γ u`` over ``dt`` with ``u`` held: ``[[Φ, Γ], [0, I]] = expm([[A, B], [0, 0]] dt)``.

    ``a`` (..., n, n), ``b`` (..., n, m) and ``dt`` (scalar or the batch shape) broadcast.
    """
    dt = np.asarray(dt, dtype=float)
    if not np.all(dt >= 0):
        raise ValueError(f"dt must be >= 0, got {dt}")
    n = a.shape[-1]
    exp = scipy.linalg.expm(augmented(a, b) * dt[..., None, None])
    return exp[..., :n, :n], exp[..., :n, n:]


def push_expansion(a: np.ndarray, b: np.ndarray, a_push: np.ndarray, b_push: np.ndarray,
                   dt: float, order: int = 2) -> np.ndarray:
    """Coefficients ``C_k`` (k = 0 … order) of ``[Φ(ε), Γ(ε)] = C_0 + ε C_1 + ε² C_2 + … + O(ε^(order+1))``.

    ``Φ(ε), Γ(ε)`` is the exact step of ``A + ε A_F``, ``B + ε B_F`` (the push scaled by
    ``1 + ε``). With ``X = [[A, B], [0, 0]] dt`` and ``E`` the same built of ``A_F, B_F``,
    the exponential of the block matrix ``[[X, E, 0], [0, X, E], [0, 0, X]]`` holds
    ``e^X`` on its diagonal, the first derivative ``d/dε e^{X+εE}`` in block (0, 1) and
    half the second in block (0, 2) (the exponential of a block-Toeplitz generator is
    the Taylor series of ``e^{X+εE}`` in ``ε``; Van Loan 1978 uses the same device);
    a larger ``order`` makes the block matrix larger the same way. With ``order = 2`` the
    error is the third-order term: for a push noise of 1 % per step it is ~1e-9 of the
    state per step (measured in the tests against ``expm``).

    Returns an array (..., order + 1, n, n + m): the rows of ``[Φ, Γ]`` for each power of ``ε``.
    """
    n, terms = a.shape[-1], order + 1
    x, e = augmented(a, b) * dt, augmented(a_push, b_push) * dt
    k = x.shape[-1]
    block = np.zeros((*x.shape[:-2], terms * k, terms * k))
    for i in range(terms):
        block[..., i * k:(i + 1) * k, i * k:(i + 1) * k] = x
    for i in range(terms - 1):
        block[..., i * k:(i + 1) * k, (i + 1) * k:(i + 2) * k] = e
    exp = scipy.linalg.expm(block)
    return np.stack([exp[..., :n, j * k:(j + 1) * k] for j in range(terms)], axis=-3)


def sample_gaussian(mean: np.ndarray, cov: np.ndarray, normals: np.ndarray, xp: Any = np) -> np.ndarray:
    """``mean + std · C^½ ξ`` for standard normals ``ξ`` (batched over leading axes): a draw from
    ``N(mean, cov)`` that is a continuous function of the covariance.

    The covariance is first scaled to its correlation matrix ``C`` by its diagonal, so the
    eigensolver sees entries of order one whatever the physical scales (a coast of minutes can
    leave variances of 1e-20 m² beside 1e+10 (m/s)²); a component with zero variance stays
    exactly at its mean. ``C^½`` is :func:`symmetric_root`: unlike ``V √Λ`` it does not depend on
    the signs and rotations the eigensolver picks for its eigenvectors, which differ between
    LAPACK drivers and CPU kernels, so a seed draws the same state on every machine (to round-off;
    docs/physics.md §3). ``xp`` is the array module (``jax.numpy`` for the JAX backend).
    """
    std = xp.sqrt(xp.clip(xp.diagonal(cov, axis1=-2, axis2=-1), 0.0, None))
    safe = xp.where(std > 0, std, 1.0)
    corr = cov / (safe[..., :, None] * safe[..., None, :])
    root = symmetric_root(corr, xp)
    return mean + std * (root @ normals[..., None])[..., 0]


def symmetric_root(matrix: np.ndarray, xp: Any = np) -> np.ndarray:
    """The unique symmetric positive semi-definite square root ``V √Λ Vᵀ`` of symmetric matrices
    (..., n, n); negative eigenvalues from round-off count as zero.

    It is a function of the matrix alone (any orthonormal basis of an eigenspace gives the same
    product) and continuous: ``‖A^½ − B^½‖ ≤ ‖A − B‖^½`` for positive semi-definite ``A, B``, and
    Lipschitz where ``A`` is positive definite. The input is symmetrised first, so no solver's
    choice of triangle matters either. ``xp`` as :func:`sample_gaussian`'s.
    """
    symmetric = 0.5 * (matrix + xp.swapaxes(matrix, -1, -2))
    eigval, eigvec = xp.linalg.eigh(symmetric)
    scaled = eigvec * xp.sqrt(xp.clip(eigval, 0.0, None))[..., None, :]
    return scaled @ xp.swapaxes(eigvec, -1, -2)


def sample_uniform(rng: np.random.Generator, low: np.ndarray | float, high: np.ndarray | float,
                   size: int) -> np.ndarray:
    """``rng.uniform(low, high, size)``, the same numbers, without its per-call argument checks
    (15 µs against 1 µs for four numbers; the episode core draws once per environment)."""
    return low + (high - low) * rng.random(size)


#: Relative difference below which :func:`mode_rates` takes two frequencies as one mode.
SAME_MODE = 1e-2


def mode_rates(a: np.ndarray, resolution: float = 1e-2) -> tuple[np.ndarray, np.ndarray]:
    """Growth rate (...,) and the slowest and fastest distinct oscillation frequencies (..., 2;
    NaN where there are fewer) [1/s, rad/s] of system matrices (..., n, n), from their eigenvalues.

    Imaginary parts below ``resolution`` [rad/s] are not oscillations: a defective double zero
    (a neutral direction) splits by round-off into ``±√ε``, which is no mode to look ahead over.
    Frequencies within :data:`SAME_MODE` of each other count as one: a spin splits each pair
    of x/y modes by ``~(I_a/I_t) Ω`` into two whose slow beat turns the oscillation's plane
    (precession) but hardly changes ``|V⊥|``; looking ahead over that beat would take minutes.
    """
    eig = np.linalg.eigvals(a)
    growth = np.maximum(eig.real.max(axis=-1), 0.0)
    imag = np.where(eig.imag > resolution, eig.imag, np.nan)
    oscillating = ~np.all(np.isnan(imag), axis=-1)
    with np.errstate(invalid="ignore"):
        filled = np.where(oscillating[..., None], imag, 0.0)
        low, high = np.nanmin(filled, axis=-1), np.nanmax(filled, axis=-1)
    low = np.where(oscillating, low, np.nan)
    high = np.where(oscillating & (high > low * (1 + SAME_MODE)), high, np.nan)
    return growth, np.stack([low, high], axis=-1)
