"""The fast coast (``make(..., coast="fast")``): each draw's coast pieces built once, an episode's coast a
few small products.

A realistic 3D episode coasts ~590 s to cut-off in ~118 pieces of 5 s, each the exponential of a second-moment
generator (:mod:`sail_env.jax.along`): ~370 times the window's cost. Nothing in a piece's propagator depends on
the episode but three things: the draw, the piece's flight times and the command held. Two changes make all
of it the draw's alone:

* **The command as a state.** With ``u`` held as constant states, the second moments of ``(s, u, 1)`` move
  under one generator ``G'`` for every command (:meth:`~sail_env.jax.along.Coast.held_generator`), and
  ``R e^{G' t} L(u) = e^{G(u) t}`` exactly (:func:`~sail_env.physics.noise.held_input_maps`: the lifted
  moments of a known command stay lifted). A piece that starts from a drawn state ``s`` starts from the
  moments ``vech(z zᵀ)`` of the known ``z = (s, u, 1)``, so ``R e^{G' t}`` (h × h', 45 × 91 on the 3D tasks)
  maps them to the piece's end moments for any ``u``.
* **A schedule fixed per draw.** The default coast splits each coast evenly, so its pieces move with the
  cut-off's jitter. Here the pieces run from the coast's start (the window's end and the commands in flight:
  the draw's alone) in whole pieces of :data:`~sail_env.physics.rigid3d.plant.COAST_SEGMENT_S` (shorter
  where the draw's growth needs it), then one remainder piece to the episode's cut-off, computed per episode
  as the default coast computes its pieces. Each piece holds the model at its middle and is split where a
  kink falls inside it, as the default's; every piece is at most 5 s, where the coast is converged
  (docs/physics.md §14), and draws the state at its end from the exact moments, as the default's.

So the episodes are the default coast's in law, not draw for draw: the same model, noise and cadence on
another grid of piece ends. Each draw's maps (``P`` whole pieces) are built at :func:`fast_coast_of` and cost
``K·P·h·h'`` floats: ~3.8 MB a draw on the 3D tasks, so the fast coast plays a smaller bank than the default
(:data:`FAST_DRAWS`).
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from sail_env.jax.along import AlongFlight, Coast, expm
from sail_env.physics.linear_plant import GROWTH_PER_PIECE
from sail_env.physics.noise import balancing, held_input_maps, mean_and_covariance, second_moment
from sail_env.physics.rigid3d.plant import COAST_SEGMENT_S

#: The bank a fast coast plays by default (``draws=``): 512 draws' maps hold ~2 GB on the 3D tasks.
FAST_DRAWS = 512
#: Pieces whose maps are built in one vectorised batch (memory ~ this × 20 matrices of h' × h').
BUILD_BATCH = 256


@struct.dataclass
class FastCoast:
    """Each draw's coast, built once (:func:`fast_coast_of`)."""

    start: jax.Array  # (K,) the coast's start [s]: the window's end with the commands in flight
    piece: jax.Array  # (K,) the whole pieces' length [s]
    maps: jax.Array  # (K, P, h, h') whole piece j's: the (s, 1) moments at its end from those of (s, u, 1) at its start
    into: jax.Array  # (h', h') and back: the lifted moments' exact change of units (balancing)
    back: jax.Array
    pre: jax.Array  # (K, Q, h, h) the coast from launch to control: Q even pieces (the most any draw's default takes)
    #: Whether a kink can fall inside a remainder piece (else its propagator is one exponential).
    rest_kinks: bool = struct.field(pytree_node=False, default=True)


def piece_length(growth: np.ndarray) -> np.ndarray:
    """The whole pieces' length [s] of draws growing at ``growth`` [1/s]: at most
    :data:`~sail_env.physics.rigid3d.plant.COAST_SEGMENT_S`, and short enough that the moments grow at most
    ``e^GROWTH_PER_PIECE`` in one (the plant's ``coast_pieces``)."""
    return np.minimum(COAST_SEGMENT_S, GROWTH_PER_PIECE / np.maximum(growth, 1e-300))


#: A correlation matrix's pivot below this counts as zero in :func:`semidefinite_cholesky` (round-off of a
#: singular one; the pivots of a correlation matrix are at most 1).
PIVOT_FLOOR = 1e-12


def semidefinite_cholesky(matrix: jax.Array) -> jax.Array:
    """A lower-triangular ``L`` with ``L Lᵀ = A`` for a positive semi-definite ``A`` (..., n, n) with unit-sized
    entries (a correlation matrix): Cholesky's columns unrolled, a pivot under :data:`PIVOT_FLOOR` (a direction
    without spread) giving a zero column. Elementwise over the batch, ~7 times cheaper than the symmetric root's
    eigensolver here; what it draws, ``L ξ``, has the same law as the symmetric root's."""
    n = matrix.shape[-1]
    columns = []
    for j in range(n):
        column = matrix[..., :, j]
        for previous in columns:
            column = column - previous * previous[..., j:j + 1]
        pivot = column[..., j]
        root = jnp.sqrt(jnp.where(pivot > PIVOT_FLOOR, pivot, 1.0))
        column = jnp.where((pivot > PIVOT_FLOOR)[..., None], column / root[..., None], 0.0)
        columns.append(jnp.where(jnp.arange(n) >= j, column, 0.0))
    return jnp.stack(columns, axis=-1)


def sample(moments: jax.Array, normals: jax.Array) -> jax.Array:
    """The state drawn from its exact second ``moments`` (``vech`` of ``(s, 1)``'s) with ``normals``: the mean
    plus the spread times the correlation's :func:`semidefinite_cholesky` factor times ``normals`` (in law the
    default coast's symmetric-root draw); NaN where the moments overflow (the sail has left the beam)."""
    mean, cov = mean_and_covariance(moments)
    finite = jnp.all(jnp.isfinite(mean)) & jnp.all(jnp.isfinite(cov))
    cov = jnp.where(finite, cov, 0.0)
    std = jnp.sqrt(jnp.clip(jnp.diagonal(cov), 0.0, None))
    safe = jnp.where(std > 0, std, 1.0)
    factor = semidefinite_cholesky(cov / (safe[:, None] * safe[None, :]))
    return jnp.where(finite, mean + std * (factor @ normals), jnp.nan)


def lifted_moments(x: jax.Array, u: jax.Array) -> jax.Array:
    """``vech`` of the second moments of the known ``(x, u, 1)``."""
    z = jnp.concatenate([x, u])
    return second_moment(z, jnp.zeros((z.shape[0], z.shape[0]), z.dtype), xp=jnp)


def fast_coast_of(coast: Coast, along: AlongFlight, start: np.ndarray, cutoffs: tuple[float, float],
                  units: np.ndarray, pre_control: np.ndarray, pre_pieces: int, into_small: jax.Array,
                  back_small: jax.Array) -> FastCoast:
    """Every draw's whole pieces from its coast's ``start`` (K,) to before the latest of the ``cutoffs``
    (earliest, latest) [s]; ``units`` (n + m,): the state's and the command's scales (the balancing of the
    exponentials); and the coast from launch to each draw's ``pre_control`` (K,) in ``pre_pieces`` even pieces
    with no command (``into_small``/``back_small``: the (s, 1) moments' balancing). A ``ValueError`` where a
    piece's exponential does not converge (NaN)."""
    earliest, latest_cutoff = cutoffs
    growth = np.asarray(along.growth, np.float64)
    piece = piece_length(growth)
    whole = int(np.max(np.floor((latest_cutoff - start) / piece)))
    k, n, m = len(start), coast.n, coast.m
    pick = jnp.asarray(held_input_maps(n, m)[0])
    into, back = (jnp.asarray(a) for a in balancing(units))
    start_j, piece_j = jnp.asarray(start), jnp.asarray(piece)

    def plain(index: jax.Array) -> jax.Array:
        d, j = index // whole, index % whole
        lo = start_j[d] + j * piece_j[d]
        generator = coast.held_generator(along, d, lo + 0.5 * piece_j[d])
        return pick @ (expm(generator * (piece_j[d] * into)) * back)

    flat = jax.lax.map(jax.jit(plain), jnp.arange(k * whole), batch_size=BUILD_BATCH)
    maps = np.array(flat).reshape(k, whole, *flat.shape[1:])
    del flat  # ~2 GB at 512 draws: not held three times over
    if along.kink_distances.shape[0]:  # the pieces a kink falls in: their parts' product, as the default's
        def split(index: jax.Array) -> jax.Array:
            d, j = index // whole, index % whole
            lo = start_j[d] + j * piece_j[d]
            return jnp.any(coast._cuts(along, d, lo, lo + piece_j[d]) < lo + piece_j[d])

        def composed(index: jax.Array) -> jax.Array:
            d, j = index // whole, index % whole
            lo = start_j[d] + j * piece_j[d]
            return pick @ coast.span_propagator(along, d, lo, lo + piece_j[d],
                                                lambda t: coast.held_generator(along, d, t), into, back)

        rows = np.flatnonzero(np.asarray(jax.jit(jax.vmap(split))(jnp.arange(k * whole))))
        if len(rows):
            parts = np.array(jax.lax.map(jax.jit(composed), jnp.asarray(rows), batch_size=BUILD_BATCH))
            maps.reshape(k * whole, *maps.shape[2:])[rows] = parts
    rest_kinks = False
    if along.kink_distances.shape[0]:  # a kink between the earliest remainder's start and the latest cut-off
        first_rest = start + np.floor((earliest - start) / piece) * piece
        rest_kinks = bool(np.any(np.asarray(jax.jit(jax.vmap(
            lambda d, lo: jnp.any(coast._cuts(along, d, lo, jnp.asarray(latest_cutoff)) < latest_cutoff)))(
            jnp.arange(k), jnp.asarray(first_rest)))))
    zero = jnp.zeros(m)

    def pre(d: jax.Array, q: jax.Array) -> jax.Array:
        length = pre_control[d] / pre_pieces
        return coast.span_propagator(along, d, q * length, (q + 1) * length,
                                     lambda t: coast.generator(along, d, zero, t), into_small, back_small)

    draws, pieces = (a.ravel() for a in np.meshgrid(np.arange(k), np.arange(pre_pieces), indexing="ij"))
    pre_control = jnp.asarray(pre_control)
    launch = np.array(jax.lax.map(jax.jit(lambda i: pre(jnp.asarray(draws)[i], jnp.asarray(pieces)[i])),
                                  jnp.arange(k * pre_pieces), batch_size=BUILD_BATCH)).reshape(k, pre_pieces, *into_small.shape)
    if not (np.all(np.isfinite(maps)) and np.all(np.isfinite(launch))):
        raise ValueError("coast='fast': a coast piece's exponential did not converge (this task's sail is too "
                         "fast for its pieces)")
    return FastCoast(start=start_j, piece=piece_j, maps=jnp.asarray(maps), into=into, back=back,
                     pre=jnp.asarray(launch), rest_kinks=rest_kinks)


def fast_coast(coast: Coast, along: AlongFlight, fast: FastCoast, d: jax.Array, x: jax.Array, u: jax.Array,
               cutoff: jax.Array, normals: jax.Array, into: jax.Array, back: jax.Array,
               diverged: Callable) -> tuple[jax.Array, jax.Array]:
    """From ``x`` at the coast's start (draw ``d``'s) to ``cutoff`` with ``u`` held: the whole pieces
    through their maps, then the remainder piece's propagator (``into``/``back``: the (s, 1) moments'
    balancing); ``normals`` (P + 1, n) or, for paths sharing the propagators, (K, P + 1, n). Each piece's end
    drawn by :func:`sample`; ``diverged`` as :meth:`~sail_env.jax.along.Coast.coast`'s. Returns the state(s)
    at cut-off and whether each left the beam."""
    whole_max = fast.maps.shape[1]
    begin, length = fast.start[d], fast.piece[d]
    whole = jnp.minimum(jnp.floor(jnp.maximum(cutoff - begin, 0.0) / length), whole_max).astype(jnp.int32)
    last = begin + whole.astype(length.dtype) * length
    rest = coast.span_propagator(along, d, last, jnp.maximum(cutoff, last), lambda t: coast.generator(along, d, u, t),
                                 into, back, kinks=fast.rest_kinks)

    def one_path(x: jax.Array, normals: jax.Array) -> tuple[jax.Array, jax.Array]:
        def piece(j: int, carry: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
            x, lost = carry
            moved = sample(fast.maps[d, j] @ lifted_moments(x, u), normals[j])
            active = (j < whole) & ~lost
            x = jnp.where(active, moved, x)
            return x, lost | (active & diverged(x))

        x, lost = jax.lax.fori_loop(0, whole_max, piece, (x, jnp.array(False)))
        moved = sample(rest @ second_moment(x, jnp.zeros((x.shape[0], x.shape[0]), x.dtype), xp=jnp),
                       normals[whole_max])
        x = jnp.where(lost, x, moved)
        return x, lost | diverged(x)

    if normals.ndim == 2:
        return one_path(x, normals)
    return jax.vmap(one_path, in_axes=(None, 0))(x, normals)


def fast_launch(fast: FastCoast, d: jax.Array, x: jax.Array, normals: jax.Array,
                diverged: Callable) -> tuple[jax.Array, jax.Array]:
    """From the launch state ``x`` to the start of control through draw ``d``'s built pieces (``normals``
    (Q, n)): each piece's end drawn by :func:`sample`. Returns the state and whether it left the beam."""
    def piece(q: int, carry: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
        x, lost = carry
        moved = sample(fast.pre[d, q] @ second_moment(x, jnp.zeros((x.shape[0], x.shape[0]), x.dtype), xp=jnp),
                       normals[q])
        x = jnp.where(lost, x, moved)
        return x, lost | diverged(x)

    return jax.lax.fori_loop(0, fast.pre.shape[1], piece, (x, jnp.array(False)))
