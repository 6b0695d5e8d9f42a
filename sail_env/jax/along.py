"""A 3D sail whose model changes along its flight, in JAX: the noisy coast piece by piece.

``LightSail3DRealistic-v0``/``-v1``'s sail flies 600 s under a push that falls with the Doppler factor
and, beyond the diffraction length ``L0``, with the spot's widening; the ground station's pointing jitter
grows with the distance and the dust impacts with the speed. The Numba core's plant
(:meth:`~sail_env.physics.linear_plant.LinearPlant.coast`) coasts such a sail in pieces of at most
:data:`~sail_env.physics.rigid3d.plant.COAST_SEGMENT_S`, each with the model, the beam jitter's and the
impacts' intensities held at the piece's middle (the midpoint rule), a piece that contains a time where
the model has a kink (the spot starting to widen, a hard beam edge meeting the rim) split there, and the
state drawn from the exact second moments at each piece's end. This module is that coast for one
environment: the model at a time (:meth:`Coast.piece_model`, the plant's ``_coast_params``), its moment
generator (:func:`~sail_env.physics.noise.moment_generator` in ``jax.numpy``), the exponential, the
kinks (50 halvings, as the plant's ``_kink_times``) and the draws. The tables it reads (the flights,
the widened spot's terms) are the NumPy plant's own arrays (:mod:`sail_env.jax.tables`); the
per-draw arrays come from the same NumPy parameters the Numba core plays (:func:`along_of`).

Equal to the Numba core's coast to rounding, not to the bit: the logarithms of the table reads, the
sums of the generator and the two exponentials differ in their last bits (``tests/jax/test_along.py``
measures each against the plant).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from sail_env.jax import tables
from sail_env.physics.linear_plant import GROWTH_PER_PIECE
from sail_env.physics.noise import held_input_generator, moment_generator, second_moment
from sail_env.physics.rigid3d.plant import BISECTIONS, COAST_SEGMENT_S, FlightModel
from sail_env.physics.rigid3d.uncertainty import with_draw_terms

#: Squarings of a piece's exponential (:func:`expm`): a 5 s piece's balanced generator needs at most 9.8
#: on the realistic 3D tasks (measured over their draws, commands and flight times), so two to spare; the
#: env's bank refuses a task whose pieces would need more (``sail_env.jax.env``).
MAX_SQUARINGS = 12
#: Higham's (2005) degree-13 Padé approximant of ``e^x``: its coefficients ``b_0 … b_13`` and the largest
#: 1-norm ``θ_13`` it serves to double precision.
PADE13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0, 129060195264000.0,
          10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0, 40840800.0, 960960.0, 16380.0, 182.0, 1.0)
THETA13 = 5.371920351148152


def expm(matrix: jax.Array) -> jax.Array:
    """``e^A`` by scaling and squaring with the degree-13 Padé approximant (Higham 2005), always that
    degree and :data:`MAX_SQUARINGS` squarings, each taken only where the matrix's 1-norm needs it: under
    ``vmap`` every branch runs, and ``jax.scipy.linalg.expm`` would compute its five Padé degrees and all
    its squarings (twice the products). NaN where :data:`MAX_SQUARINGS` do not suffice."""
    norm = jnp.max(jnp.sum(jnp.abs(matrix), axis=0))
    needed = jnp.maximum(0.0, jnp.ceil(jnp.log2(norm / THETA13)))
    scaled = matrix / 2.0 ** jnp.minimum(needed, MAX_SQUARINGS)
    b = PADE13
    eye = jnp.eye(matrix.shape[0], dtype=matrix.dtype)
    a2 = scaled @ scaled
    a4 = a2 @ a2
    a6 = a4 @ a2
    u = scaled @ (a6 @ (b[13] * a6 + b[11] * a4 + b[9] * a2) + b[7] * a6 + b[5] * a4 + b[3] * a2 + b[1] * eye)
    v = a6 @ (b[12] * a6 + b[10] * a4 + b[8] * a2) + b[6] * a6 + b[4] * a4 + b[2] * a2 + b[0] * eye
    result = jnp.linalg.solve(v - u, v + u)
    for square in range(MAX_SQUARINGS):
        result = jnp.where(square < needed, result @ result, result)
    return jnp.where(needed <= MAX_SQUARINGS, result, jnp.nan)


@struct.dataclass
class AlongFlight:
    """What a coast along the flight reads (:func:`along_of`): the tables, shared, and per parameter draw
    (K, ...) the window's model and how the draw's radiation terms scale."""

    flights: tables.FlightArrays
    scales: tables.ScaleArrays | None  # the widened spot's terms (None: the spot never widens)
    kinematics: jax.Array  # (n, n) the part of A no radiation term scales
    radiation: jax.Array  # (n, n) the nominal sail's radiation part of A in the unwidened spot
    radiation_b: jax.Array  # (n, c) and of B, with the constant term's column
    kink_distances: jax.Array  # (J,) distances where the model has a kink (the spot starts widening, edges)
    ratio: jax.Array  # (K,) each draw's F/m over the nominal
    rows: jax.Array  # (K, n) each draw's scaling of the radiation terms' rows
    window_a: jax.Array  # (K, n, n) the window's model (the draw's A at the window's middle)
    window_b: jax.Array  # (K, n, c)
    window_power: jax.Array  # (K,) the Doppler power factor at the window's middle
    window_scale: jax.Array  # (K,) the spot's scale at the window's middle
    growth: jax.Array  # (K,) the draw's growth rate [1/s] (pieces: at most e^20 each)
    draw: DrawArrays | None = None  # each draw's own sail (the uncertain tasks; None: the nominal sail's)


@struct.dataclass
class DrawArrays:
    """A :class:`~sail_env.physics.rigid3d.uncertainty.DrawTerms`' arrays (K, ...) and, where the spot
    widens, the widened table's entries on the grid points the bank's flights reach (:func:`along_of`)."""

    near_a: jax.Array  # (K, n, n) the radiation part of A minus the nominal sail's, unwidened spot
    near_inputs: jax.Array  # (K, n, 4) and of B
    near_push: jax.Array  # (K,) the push over I_t minus the nominal sail's
    bias: jax.Array  # (K, 2) the constant beam offset at the sail [m]
    inertia: jax.Array  # (K,) I_t [kg m²]
    nominal_inertia: jax.Array
    payload_offset: jax.Array  # the CoM's distance from the axis [m]
    nominal: tables.ScaleArrays | None  # the nominal sail's entries of the widened table, on the grid reached
    drawn_a: jax.Array | None  # (K, G, n, n) s² times each draw's radiation part of A on that grid
    drawn_inputs: jax.Array | None  # (K, G, n, 4)
    drawn_push: jax.Array | None  # (K, G)
    v1_widening: bool = struct.field(pytree_node=False, default=False)


def along_of(model: FlightModel, dtype: jnp.dtype, until_s: float | None = None) -> AlongFlight:
    """The :class:`AlongFlight` of a plant's :class:`~sail_env.physics.rigid3d.plant.FlightModel` (its
    ``flight_model(p)``): every array the plant's own. The draws' own widened-spot terms are kept on the
    grid points their flights reach by ``until_s`` (None: the whole grid), and one more: 4,096 draws'
    whole grid would be 165 MB, the 7 points ``LightSailUncertain-v2``'s bank reaches 22 MB; a read beyond
    them is NaN, as beyond the table's top."""

    def array(values: Any) -> jax.Array:
        return jnp.asarray(values, dtype=dtype)

    return AlongFlight(
        flights=tables.flight_arrays(model.flights, dtype),
        scales=None if model.scales is None else tables.scale_arrays(model.scales, dtype),
        kinematics=array(model.kinematics), radiation=array(model.radiation), radiation_b=array(model.radiation_b),
        kink_distances=array(model.kink_distances), ratio=array(model.ratio), rows=array(model.rows),
        window_a=array(model.window_a), window_b=array(model.window_b), window_power=array(model.window_power),
        window_scale=array(model.window_scale), growth=array(model.growth),
        draw=None if model.draw is None else _draw_arrays(model, dtype, until_s))


def _draw_arrays(model: FlightModel, dtype: jnp.dtype, until_s: float | None) -> DrawArrays:
    """The :class:`DrawArrays` of a :class:`FlightModel` whose draws fly their own sails."""
    terms = model.draw

    def array(values: Any) -> jax.Array:
        return jnp.asarray(values, dtype=dtype)

    nominal = drawn = None
    if terms.widened is not None:
        grid = terms.widened.log_scales
        reach = grid[-1] if until_s is None else np.log(np.max(model.flights.beam_scale(
            model.ratio, np.full(len(model.ratio), until_s))))
        points = min(len(grid), int(np.searchsorted(grid, reach, side="right")) + 1)  # at least s = 1 and the next
        drawn, entries = terms.grids(points)
        nominal = tables.ScaleArrays(log_scales=array(grid[:points]), radiation=array(entries[0]),
                                     inputs=array(entries[1]), push=array(entries[2]), log_top=array(grid[points - 1]))
    return DrawArrays(
        near_a=array(terms.near_a), near_inputs=array(terms.near_inputs), near_push=array(terms.near_push),
        bias=array(terms.bias), inertia=array(terms.inertia), nominal_inertia=array(terms.nominal_inertia),
        payload_offset=array(terms.payload_offset), nominal=nominal,
        drawn_a=None if drawn is None else array(drawn[0]), drawn_inputs=None if drawn is None else array(drawn[1]),
        drawn_push=None if drawn is None else array(drawn[2]), v1_widening=terms.v1_widening)


class Coast:
    """The coast along the flight of one task's plant: its static structure (its rows, noises and laws,
    from the plant and its :class:`~sail_env.physics.rigid3d.plant.FlightModel`) and the pure functions
    over an :class:`AlongFlight`."""

    def __init__(self, plant: Any, model: FlightModel) -> None:
        self.plant, self.model = plant, model
        self.n, self.m = plant.n_states, plant.n_inputs
        self.biased = model.radiation_b.shape[1] > self.m
        self.jitter_inputs = tuple(plant.jitter_inputs) if plant.jittered else ()
        self.impulse_rows = tuple(plant.impulse_rows)

    # ------------------------------------------------------------------ the flight
    def speed(self, along: AlongFlight, d: jax.Array, t: jax.Array) -> jax.Array:
        """The draw's axial speed at ``t`` (the plant's ``speed``: the flight's, or ``a t``)."""
        if self.model.relativistic_speed:
            return tables.flight_speed(along.flights, along.ratio[d], t)
        return along.ratio[d] * self.model.nominal_acceleration * t

    def _power(self, along: AlongFlight, d: jax.Array, t: jax.Array) -> jax.Array:
        return tables.flight_power_factor(along.flights, along.ratio[d], t)

    # ------------------------------------------------------------------ the model at a time
    def radiation_in_spot(self, along: AlongFlight, scale: jax.Array) -> tuple[jax.Array, jax.Array]:
        """The nominal sail's radiation part of ``A`` (n, n) and ``B`` (n, c) in the spot widened by
        ``scale`` (the plant's ``_radiation``): the unwidened spot's up to ``s = 1``."""
        widened = tables.scale_blend(along.scales, "radiation", scale)
        inputs = tables.scale_blend(along.scales, "inputs", scale)
        columns = [inputs, jnp.zeros((self.n, self.m - inputs.shape[1]), inputs.dtype)]
        if self.biased:
            push = tables.scale_blend(along.scales, "push", scale)
            columns.append(self.model.payload_column(widened, push, xp=jnp)[:, None])
        near = scale <= 1.0
        return (jnp.where(near, along.radiation, widened),
                jnp.where(near, along.radiation_b, jnp.concatenate(columns, axis=1)))

    def draw_in_spot(self, along: AlongFlight, d: jax.Array, scale: jax.Array, radiation: jax.Array,
                     inputs: jax.Array) -> tuple[jax.Array, jax.Array]:
        """Draw ``d``'s own radiation part of ``A`` and ``B`` in the spot widened by ``scale``, from the nominal
        sail's there (the uncertain plant's ``draw_radiation``): its differences from the nominal sail in
        that spot, or in the unwidened one (``v1_widening``, or a spot not widened)."""
        terms = along.draw
        delta_a, delta_inputs, delta_push = terms.near_a[d], terms.near_inputs[d], terms.near_push[d]
        if terms.nominal is not None:
            far = scale > 1.0
            drawn = [tables.scale_blend(terms.nominal, table[d], scale)
                     for table in (terms.drawn_a, terms.drawn_inputs, terms.drawn_push)]
            nominal = [tables.scale_blend(terms.nominal, name, scale) for name in ("radiation", "inputs", "push")]
            delta_a = jnp.where(far, drawn[0] - nominal[0], delta_a)
            delta_inputs = jnp.where(far, drawn[1] - nominal[1], delta_inputs)
            delta_push = jnp.where(far, drawn[2] / terms.inertia[d] - nominal[2] / terms.nominal_inertia, delta_push)
        offsets = (along.radiation_b if terms.v1_widening else inputs)[:, :2]
        return with_draw_terms(radiation, inputs, delta_a, delta_inputs, delta_push, terms.bias[d], offsets,
                               terms.payload_offset, xp=jnp)

    def piece_model(self, along: AlongFlight, d: jax.Array, t: jax.Array) -> tuple[jax.Array, jax.Array]:
        """``(A, B)`` of draw ``d`` at flight time ``t`` (the plant's ``_coast_params``): the window's model
        with the radiation terms scaled by the power factor at ``t`` over the window's, or, where the
        draw's spot at ``t`` is not the window's, the draw's rows times the terms of that spot."""
        power = self._power(along, d, t)
        relative = power / along.window_power[d]
        a_rad = along.window_a[d] - along.kinematics
        a = jnp.where(relative == 1.0, along.window_a[d], along.kinematics + relative * a_rad)
        b = jnp.where(relative == 1.0, along.window_b[d], relative * along.window_b[d])
        if along.scales is None:
            return a, b
        scale = tables.beam_scale(along.flights, along.ratio[d], t)
        rows = along.rows[d] * power
        radiation, inputs = self.radiation_in_spot(along, scale)
        if along.draw is not None:
            radiation, inputs = self.draw_in_spot(along, d, scale, radiation, inputs)
        widened = scale != along.window_scale[d]
        return (jnp.where(widened, along.kinematics + rows[:, None] * radiation, a),
                jnp.where(widened, rows[:, None] * inputs, b))

    def _noise_terms(self, along: AlongFlight, d: jax.Array, t: jax.Array) -> tuple:
        """Draw ``d``'s model at flight time ``t`` and its noises (the plant's ``_moment_terms``): ``(A, B)``,
        the beam jitter's intensity at the draw's distance at ``t`` and the impacts' at its speed."""
        a, b = self.piece_model(along, d, t)
        distance = tables.flight_distance(along.flights, along.ratio[d], t) if self.model.reads_distance else None
        std = self.plant.jitter_std_along(distance, jnp)
        jitter_psd = jnp.asarray(std, a.dtype) ** 2 * self.model.dt
        impacts = None
        if self.impulse_rows:
            rate, kick = self.plant.impacts_along(self.speed(along, d, t), jnp)
            rows = jnp.array(self.impulse_rows)
            impacts = jnp.zeros((self.n, self.n), a.dtype).at[rows, rows].set(jnp.asarray(rate * kick ** 2, a.dtype))
        return a, b, jitter_psd, impacts

    def generator(self, along: AlongFlight, d: jax.Array, u: jax.Array, t: jax.Array) -> jax.Array:
        """The second moments' generator (h, h) of draw ``d`` with ``u`` held at flight time ``t`` (the
        plant's ``_moment_generator``): the push noise, the beam jitter of the draw's distance at ``t``,
        the impacts of its speed at ``t``."""
        a, b, jitter_psd, impacts = self._noise_terms(along, d, t)
        held = jnp.concatenate([u, jnp.ones(1, u.dtype)]) if self.biased else u
        return moment_generator(a, b, held, self.model.noise, (a - along.kinematics, b), self.jitter_inputs,
                                jitter_psd, impacts, xp=jnp)

    def held_generator(self, along: AlongFlight, d: jax.Array, t: jax.Array) -> jax.Array:
        """:meth:`generator` for every held command at once (h', h'): the second moments' generator of
        ``(s, u, 1)``, the command as constant states (:func:`~sail_env.physics.noise.held_input_generator`;
        the plant's constant term joins the constant's column). ``R G' L(u)`` is :meth:`generator`'s
        ``u`` (:func:`~sail_env.physics.noise.held_input_maps`)."""
        a, b, jitter_psd, impacts = self._noise_terms(along, d, t)
        return held_input_generator(a, b, self.model.noise, (a - along.kinematics, b), self.jitter_inputs,
                                    jitter_psd, impacts, held=self.m, xp=jnp)

    # ------------------------------------------------------------------ the coast
    def pieces(self, along: AlongFlight, d: jax.Array, duration: jax.Array) -> jax.Array:
        """How many pieces the plant splits a coast of ``duration`` into (``coast_pieces``)."""
        grown = jnp.ceil(duration * along.growth[d] / GROWTH_PER_PIECE)
        return jnp.maximum(jnp.maximum(1.0, grown), jnp.ceil(duration / COAST_SEGMENT_S)).astype(jnp.int32)

    def _cuts(self, along: AlongFlight, d: jax.Array, lo: jax.Array, hi: jax.Array) -> jax.Array:
        """The times (J,) in ``[lo, hi]`` where draw ``d``'s model has a kink, in order, ``hi`` for a kink
        not in the piece (the plant's ``_kink_times``: 50 halvings of the distance)."""
        ratio = along.ratio[d]

        def distance(t: jax.Array) -> jax.Array:
            return tables.flight_distance(along.flights, ratio, t)

        near, far = distance(lo), distance(hi)

        def cut(target: jax.Array) -> jax.Array:
            def halve(_: int, bounds: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
                below, above = bounds
                half = 0.5 * (below + above)
                short = distance(half) < target
                return jnp.where(short, half, below), jnp.where(short, above, half)

            _, above = jax.lax.fori_loop(0, BISECTIONS, halve, (lo, hi))
            return jnp.where((near < target) & (target < far), above, hi)

        return jnp.sort(jax.vmap(cut)(along.kink_distances))

    def span_propagator(self, along: AlongFlight, d: jax.Array, lo: jax.Array, hi: jax.Array,
                        generator_at: Callable[[jax.Array], jax.Array], into: jax.Array,
                        back: jax.Array, kinks: bool = True) -> jax.Array:
        """The moments' propagator over ``[lo, hi]`` of draw ``d`` with ``generator_at(t)`` its generator
        held at ``t`` (``into``/``back``: the balancing): one exponential held at the middle, where no kink
        falls inside; else the product of its parts' (the plant's ``_piece_propagators``). ``kinks=False``:
        known to have none inside (one exponential, not one a part)."""
        kinks = along.kink_distances.shape[0] if kinks else 0
        if not kinks:
            return expm(generator_at(0.5 * (lo + hi)) * ((hi - lo) * into)) * back
        bounds = jnp.concatenate([lo[None], self._cuts(along, d, lo, hi), hi[None]])
        total = jnp.eye(into.shape[0], dtype=into.dtype)
        for part in range(kinks + 1):
            first, last = bounds[part], bounds[part + 1]
            total = (expm(generator_at(0.5 * (first + last)) * ((last - first) * into)) * back) @ total
        return total

    def coast(self, along: AlongFlight, d: jax.Array, x: jax.Array, u: jax.Array, start: jax.Array,
              duration: jax.Array, normals: jax.Array, into: jax.Array, back: jax.Array, sample: Any,
              diverged: Any) -> tuple[jax.Array, jax.Array]:
        """From ``x`` at flight time ``start`` for ``duration`` seconds with ``u`` held: the plant's
        ``coast``. ``normals`` (P, n) are the pieces' (P at least the most pieces this coast can take);
        ``into``/``back`` the moments' change of units (:func:`~sail_env.physics.noise.balancing`);
        ``sample(moments, x, normals)`` draws the state from its second moments, ``diverged(x)`` the
        plant's rule. Returns the state and whether the sail left the beam (the state as it was caught)."""
        count = self.pieces(along, d, duration)
        piece = duration / count.astype(duration.dtype)
        kinks = along.kink_distances.shape[0]

        def segment(_: int, carry: tuple) -> tuple:
            x, moments, j, q, lost = carry
            middle = start + (j.astype(piece.dtype) + 0.5) * piece
            lo, hi = middle - 0.5 * piece, middle + 0.5 * piece
            cuts = self._cuts(along, d, lo, hi) if kinks else jnp.zeros(0, piece.dtype)
            inner = jnp.sum(cuts < hi)
            bounds = jnp.concatenate([lo[None], cuts, hi[None]])
            first, last = bounds[q], jnp.where(q < inner, bounds[q + 1], hi)
            split = inner > 0
            at = jnp.where(split, 0.5 * (first + last), middle)
            length = jnp.where(split, last - first, piece)
            generator = self.generator(along, d, u, at)
            propagator = expm(generator * (length * into)) * back
            begun = jnp.where(q == 0, second_moment(x, jnp.zeros((self.n, self.n), x.dtype), xp=jnp), moments)
            moments = propagator @ begun
            active = (j < count) & ~lost
            ends = q == inner
            moved = sample(moments, x, normals[jnp.minimum(j, normals.shape[0] - 1)])
            take = active & ends
            x = jnp.where(take, moved, x)
            lost = lost | (take & diverged(x))
            q = jnp.where(active, jnp.where(ends, 0, q + 1), q)
            j = jnp.where(active & ends, j + 1, j)
            return x, moments, j, q, lost

        h = (self.n + 1) * (self.n + 2) // 2
        carry = (x, jnp.zeros(h, x.dtype), jnp.zeros((), jnp.int32), jnp.zeros((), jnp.int32), jnp.array(False))
        x, _, _, _, lost = jax.lax.fori_loop(0, normals.shape[0] + kinks, segment, carry)
        return x, lost
