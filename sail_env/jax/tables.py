"""The 3D tasks' two physics tables read in JAX: the draws' flights and the widened spot's radiation terms.

The realistic 3D tasks read two tables built once by the NumPy physics along every flight: the axial flight
of each draw's ``F/m`` (:class:`~sail_env.physics.rigid3d.flight.DrawFlights`: speed, Doppler power factor,
distance, the spot's widening) and the radiation part of ``A`` and ``B`` and the push in a spot widened by
``s`` (:class:`~sail_env.physics.rigid3d.scales.ScaleTable`). A coast or a step whose model changes along the
flight needs them inside ``jit``; this module hands their arrays over once (:func:`flight_arrays`,
:func:`scale_arrays`) and reads them with pure functions of one ``(ratio, t)`` pair or one scale (``vmap``
batches them), operation for operation as the NumPy methods do, so that the reads are the same numbers.

**What is bit-equal.** Everything but the logarithm: the interval search and the Hermite read of the
flight table (the compiled ``_read_node``/``_hermite``), ``np.interp``'s formula, the two rows' mix, the
picks (``β``, the power factor) as the batch path computes them (``** 0.5`` of an array is NumPy's
``sqrt``, ``** 2`` its square), and ``_blend``'s mix and ``1/s²``. ``ln r`` and ``ln s`` are XLA's
``log``; NumPy's ``np.log`` is another implementation (SIMD on CPUs with AVX-512) and differs from it
by 1 ulp for ~0.1-0.6 % of arguments (measured on 400,000; XLA's equals Python's ``math.log`` there), which
moves the mix's weight by an ulp or so. ``tests/jax/test_tables.py`` finds the reads bit-equal to NumPy's
fed XLA's logarithm, and with NumPy's own the flights' within 3 ulp and the scale table's within 2.2e-15 of
the entries mixed (which can change fivefold between two grid points, or nearly cancel: up to 4.7e-14 of
such a read). (The flights' own scalar path, ``DrawFlights._read_one``, takes ``math.log`` and Python's
``** 0.5`` and ``** 2``, the C library's ``pow``: it differs from the batch path by an ulp in up to ~0.3 %
of reads.)

**Out of range.** Under ``jit`` nothing can raise: where NumPy raises (a flight time beyond the tabled
flight, ``r t > duration (1 + 1e-12)``; a scale beyond the table's top) the reads are NaN, and so they are
where NumPy reads no meaningful value (``t < 0`` or ``r ≤ 0``, which NumPy does not check). A ratio outside
the draws' ``[1/r_max, r_max]`` reads the end flight at ``r t`` (``np.interp`` clamps), as NumPy does; a
scale ``s ≤ 1`` reads the first entry, as NumPy does.

XLA's simplifier rewrites some of these operations into others that round differently; where it did, a
barrier keeps the written one: a division by a value ``vmap`` may share (``r``, ``L0``) or by a square root
is :func:`~sail_env.jax.arith.divide`'s, and the two flights' picks are mixed behind an optimisation barrier
(measured: without them an ulp off in up to a quarter of the speeds). On a CPU the reads are the NumPy
numbers only without fused multiply-adds (``XLA_FLAGS=--xla_cpu_max_isa=AVX``, :mod:`sail_env.jax.arith`;
with them, within 1e-14 relative). In float32 (``dtype``) they are the same operations in single precision,
within ~1e-6 relative of the float64 reads (``tests/jax/test_tables.py``).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
from flax import struct

from sail_env.jax.arith import divide
from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.rigid3d import flight
from sail_env.physics.rigid3d.flight import DrawFlights
from sail_env.physics.rigid3d.scales import ScaleTable

#: Relative slack beyond the tabled flight within which NumPy still reads (``DrawFlights._both``).
FLIGHT_SLACK = 1e-12
#: Slack in ``ln s`` beyond the scale table's top within which NumPy still reads (``ScaleTable._blend``).
SCALE_SLACK = 1e-12


@struct.dataclass
class FlightArrays:
    """A :class:`~sail_env.physics.rigid3d.flight.DrawFlights`' arrays (:func:`flight_arrays`): ``F`` flights
    (one without diffraction, where every draw is the nominal flight rescaled) of ``T`` nodes each."""

    nodes: jax.Array  # (F, T, 6) each node's (time, γβ, d(γβ)/dt, D, dD/dt, d²D/dt²); β for Newton
    kink_times: jax.Array  # (F, K) extra nodes: L0's crossing and each kink of the push (beyond the end if never)
    step: jax.Array  # the uniform grid's spacing h [s]
    log_ratios: jax.Array  # (F,) each flight's ln r
    diffraction_length_m: jax.Array  # L0 (inf: no diffraction)
    duration_s: jax.Array  # the nominal flight's tabled time, the latest r t read
    relativistic: bool = struct.field(pytree_node=False)


@struct.dataclass
class ScaleArrays:
    """A :class:`~sail_env.physics.rigid3d.scales.ScaleTable`'s arrays (:func:`scale_arrays`), each entry
    ``s²`` times the term at the grid's ``s`` (what ``_blend`` interpolates)."""

    log_scales: jax.Array  # (G,) the grid of ln s, its first point s = 1
    radiation: jax.Array  # (G, 8, 8) s² times the radiation part of A
    inputs: jax.Array  # (G, 8, 4) s² times the radiation part of B
    push: jax.Array  # (G,) s² times the centred sail's push [N]
    log_top: jax.Array  # ln max(top, 1): the largest ln s served


def flight_arrays(flights: DrawFlights, dtype: jnp.dtype = jnp.float64) -> FlightArrays:
    """The arrays of ``flights`` in ``dtype``."""

    def array(values: object) -> jax.Array:
        return jnp.asarray(values, dtype=dtype)

    table = flights.table
    return FlightArrays(nodes=array(table._nodes), kink_times=array(table.kink_times), step=array(table.step),
                        log_ratios=array(flights.log_ratios),
                        diffraction_length_m=array(flights.diffraction_length_m),
                        duration_s=array(flights.nominal.duration_s), relativistic=flights.relativistic)


def scale_arrays(scales: ScaleTable, dtype: jnp.dtype = jnp.float64) -> ScaleArrays:
    """The arrays of ``scales`` in ``dtype``."""

    def array(values: object) -> jax.Array:
        return jnp.asarray(values, dtype=dtype)

    return ScaleArrays(log_scales=array(scales.log_scales), radiation=array(scales._radiation),
                       inputs=array(scales._inputs), push=array(scales._push),
                       log_top=array(math.log(max(scales.top, 1.0))))


def _grid_position(x: jax.Array, grid: jax.Array) -> jax.Array:
    """``np.interp(x, grid, arange(len(grid)))``: NumPy's ends (``grid[0]`` and below give 0, ``grid[-1]`` and
    above the last index, exactly) and, within, its formula ``slope (x − grid[j]) + j`` with the slope
    ``(f[j+1] − f[j]) / (grid[j+1] − grid[j])`` of ``f = arange``, whose numerator is exactly 1."""
    last = grid.shape[0] - 1
    j = jnp.clip(jnp.sum(grid <= x) - 1, 0, max(last - 1, 0))
    left = j.astype(x.dtype)
    inside = 1.0 / (grid[j + 1] - grid[j]) * (x - grid[j]) + left
    return jnp.where(x <= grid[0], 0.0, jnp.where(x >= grid[last], float(last), inside)).astype(x.dtype)


#: ``(γβ, D)`` at ``t`` between two nodes (6,), cubic in ``γβ`` and quintic in ``D``: the flight table's own
#: compiled function's Python source (:func:`sail_env.physics.rigid3d.flight._hermite`), traced by JAX, so
#: the formula is written once and its expressions keep their order.
_hermite = flight._hermite.py_func


@jax.jit  # traced once per trace, not at each of its reads (8 for the four quantities): tracing 4x faster
def _read_node(arrays: FlightArrays, row: jax.Array, t: jax.Array) -> tuple[jax.Array, jax.Array]:
    """``(γβ, D)`` of flight ``row`` at time ``t`` (``_read_node``): the interval is ``⌊t/h⌋`` (truncated, as
    NumPy's ``int64``) plus the kinks at or before ``t``, at most the last; and, below, at least the first
    (NumPy wraps a negative index; such a ``t`` reads NaN here, :func:`_flight_read`)."""
    index = (t * (1.0 / arrays.step)).astype(jnp.int32) + jnp.sum(arrays.kink_times[row] <= t, dtype=jnp.int32)
    index = jnp.clip(index, 0, arrays.nodes.shape[1] - 2)
    return _hermite(t, arrays.nodes[row, index], arrays.nodes[row, index + 1])


def _speed(momentum: jax.Array, relativistic: bool) -> jax.Array:
    """``β c`` of ``γβ`` (``_pick_speed``): ``γβ / √(1 + (γβ)²)``; Newton's table holds ``β``. (XLA turns a
    plain ``a / sqrt(b)`` into ``a * rsqrt(b)``, off by an ulp in ~1/6 of the reads: measured.)"""
    beta = divide(momentum, jnp.sqrt(1.0 + momentum * momentum)) if relativistic else momentum
    return beta * SPEED_OF_LIGHT


def _power_factor(momentum: jax.Array, relativistic: bool) -> jax.Array:
    """``(1−β)/(1+β) = 1/(√(1+(γβ)²) + γβ)²`` (``_pick_power_factor``); 1 for Newton (NaN stays NaN)."""
    if not relativistic:
        return momentum * 0.0 + 1.0
    root = jnp.sqrt(1.0 + momentum * momentum) + momentum
    return 1.0 / (root * root)


def _flight_read(arrays: FlightArrays, ratio: jax.Array, t: jax.Array, quantity: str) -> jax.Array:
    """``DrawFlights._read``: ``quantity`` of the draw with ``ratio`` times the nominal ``F/m`` at its lab
    time ``t``, read on the nominal clock at ``r t`` from the two flights around ``ln r``, mixed linearly;
    NaN out of range (the module's docstring)."""
    ratio, t = jnp.asarray(ratio, arrays.nodes.dtype), jnp.asarray(t, arrays.nodes.dtype)
    scaled = ratio * t
    count = arrays.nodes.shape[0]

    def pick(row: jax.Array) -> jax.Array:
        momentum, distance = _read_node(arrays, row, scaled)
        if quantity == "speed":
            return _speed(momentum, arrays.relativistic)
        if quantity == "power_factor":
            return _power_factor(momentum, arrays.relativistic)
        return distance

    if count == 1:
        value = pick(jnp.zeros((), jnp.int32))
    else:
        position = _grid_position(jnp.log(ratio), arrays.log_ratios)
        low = jnp.minimum(position.astype(jnp.int32), count - 2)
        frac = position - low.astype(position.dtype)
        # Behind a barrier: with the ratio shared by ``vmap`` the weights are scalars, and XLA would fold
        # ``(1 − frac) (β c)`` into ``β ((1 − frac) c)`` (measured: an ulp off in a quarter of the speeds).
        below, above = jax.lax.optimization_barrier((pick(low), pick(low + 1)))
        value = (1 - frac) * below + frac * above
    valid = (ratio > 0) & (scaled >= 0) & (scaled <= arrays.duration_s * (1 + FLIGHT_SLACK))
    return jnp.where(valid, value, jnp.nan)


def flight_speed(arrays: FlightArrays, ratio: jax.Array, t: jax.Array) -> jax.Array:
    """The axial speed [m/s] (``DrawFlights.speed``) of the draw with ``ratio`` times the nominal ``F/m`` at
    its flight time ``t`` [s] (scalars; NaN out of range)."""
    return _flight_read(arrays, ratio, t, "speed")


def flight_power_factor(arrays: FlightArrays, ratio: jax.Array, t: jax.Array) -> jax.Array:
    """The Doppler power factor (``DrawFlights.power_factor``; 1 for Newton) of the draw ``ratio`` at ``t``."""
    return _flight_read(arrays, ratio, t, "power_factor")


def flight_distance(arrays: FlightArrays, ratio: jax.Array, t: jax.Array) -> jax.Array:
    """The distance [m] from the array (``DrawFlights.distance``: ``D̃(r t) / r``) of the draw ``ratio`` at ``t``."""
    return divide(_flight_read(arrays, ratio, t, "distance"), ratio)


def beam_scale(arrays: FlightArrays, ratio: jax.Array, t: jax.Array) -> jax.Array:
    """How much wider the spot is than at ``L0`` (``DrawFlights.beam_scale``: ``max(1, D/L0)``; 1 without
    diffraction) for the draw ``ratio`` at ``t``."""
    return jnp.maximum(1.0, divide(flight_distance(arrays, ratio, t), arrays.diffraction_length_m))


def scale_blend(arrays: ScaleArrays, table: str | jax.Array, scale: jax.Array) -> jax.Array:
    """``ScaleTable._blend`` at one scale ``s``: ``table`` (``"radiation"``, ``"inputs"``, ``"push"``, or an
    array (G, ...) on the same grid) interpolated as ``s² R`` linearly in ``ln s``, divided by ``s²``; up to
    ``s = 1`` the first entry (beyond, never mixed with it: an edge may sit at ``s = 1``); NaN beyond the
    table's top. ``ScaleTable.at`` is ``("radiation", "inputs")``, ``push_at`` is ``"push"``. A name is not
    an array: under a bare ``jit`` of this function it is a static argument."""
    values = getattr(arrays, table) if isinstance(table, str) else table
    scale = jnp.asarray(scale, values.dtype)
    log_scale = jnp.log(scale)
    grid = arrays.log_scales[1:]
    weight = _grid_position(log_scale, grid)
    low = jnp.minimum(weight.astype(jnp.int32), grid.shape[0] - 2)
    beyond = log_scale > 0.0
    index = jnp.where(beyond, 1 + low, 0)
    frac = jnp.where(beyond, weight - low.astype(weight.dtype), 0.0)
    upper = jnp.minimum(index + 1, arrays.log_scales.shape[0] - 1)
    widest = jnp.maximum(scale, 1.0)
    inverse = 1.0 / (widest * widest)
    blended = inverse * ((1 - frac) * values[index] + frac * values[upper])
    return jnp.where(log_scale > arrays.log_top + SCALE_SLACK, jnp.nan, blended)
