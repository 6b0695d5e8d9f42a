"""The 3D tasks' tables read in JAX (:mod:`sail_env.jax.tables`) against the NumPy methods they port.

Every 3D task whose plant has flights (``plant.flights``, a ``DrawFlights``) and spot scales (``plant.scales``,
a ``ScaleTable``), and the flights no task has today (one flight without diffraction, relativistic and
Newtonian; Newton's nine with diffraction), are read by ``jit(vmap(...))`` at random ``(r, t)`` over the whole
valid range (``1/r_max ≤ r ≤ r_max``, ``0 ≤ r t ≤`` the tabled flight) and exactly at the table's nodes, its
kink times and their neighbours; the scale table at random scales, its grid points and their neighbours,
``s = 1``, its top and below 1.

**Bit-equal, but for the logarithm.** The mix of two flights (or grid points) is weighted by ``ln r`` (or
``ln s``): JAX takes XLA's ``log``, NumPy ``np.log``, two implementations each within an ulp of ``ln`` (on a
CPU with AVX-512 NumPy's is its own SIMD code) that come out an ulp apart for 0.05-0.3 % of the arguments
here. So the reads are compared twice: with XLA's logarithm in NumPy's place (``np.log`` patched for the
call) NumPy's batch reads are JAX's to the bit, everywhere; with NumPy's own they are within a bound. That
ulp moves the mix's weight by ``ulp(ln r)/Δ`` and an ulp of the weight: the flights' reads then differ by at
most 3 ulp (4.4e-16 relative; measured over 400,000 random reads of each task's table); asserted: 4 ulp.
The scale table's entries can change fivefold between two grid points 5 % apart (an entry of ``A`` of
``LightSail3DRealistic-v1`` between 2,600 and 14,600 near ``s = 2``) and two of them can nearly cancel, so
its reads are bounded against the entries mixed: ``|Δ| ≤ 2⁻⁴⁶ max |R|/s²`` over the entries around the read
(measured over 400,000 scales of each task's table: up to 2.2e-15 of it, and 4.7e-14 of a read itself);
2⁻⁴⁶ (1.4e-14) leaves a margin of 6. Without ``XLA_FLAGS=--xla_cpu_max_isa=AVX`` (``conftest.py``) XLA
fuses multiply-adds and every read is compared within its bound or 1e-14 relative.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("flax")

import jax.numpy as jnp  # noqa: E402

from sail_env.envs.rigid3d import rigid3d_spec  # noqa: E402
# (sail_env.jax, imported first, turns float64 on)
from sail_env.jax.tables import (beam_scale, flight_arrays, flight_distance, flight_power_factor,  # noqa: E402
                                 flight_speed, scale_arrays, scale_blend)
from sail_env.physics.rigid3d.flight import draw_flights  # noqa: E402
from sail_env.tasks import RIGID3D_TASKS  # noqa: E402

EXACT = "--xla_cpu_max_isa=AVX" in os.environ.get("XLA_FLAGS", "")
#: The flights' reads with NumPy's logarithm: within this many ulp (measured: up to 3).
FLIGHT_ULP = 4
#: The scale table's reads with NumPy's logarithm: within this fraction of the largest entry mixed.
SCALE_BOUND = 2.0**-46
#: Random reads per table.
RANDOM = 20_000
#: Reads per call of a jitted batch.
CHUNK = 2**15
QUANTITIES = ("speed", "power_factor", "distance", "beam_scale")
READS = {"speed": flight_speed, "power_factor": flight_power_factor, "distance": flight_distance,
         "beam_scale": beam_scale}
#: The flights no task has: (relativistic, diffracting), built for LightSail3DRealistic-v1's sail.
EXTRA_FLIGHTS = ((True, False), (False, False), (False, True))


@pytest.fixture(scope="module")
def plants() -> dict:
    """Every 3D task's plant that has flights, by id (built once; their tables are cached on disk)."""
    built = {task: rigid3d_spec(**keywords).plant for task, keywords in RIGID3D_TASKS.items()}
    return {task: plant for task, plant in built.items() if plant.flights is not None}


@pytest.fixture(scope="module")
def flights(plants: dict) -> dict:
    """``(DrawFlights, r_max)`` of every task with flights and of :data:`EXTRA_FLIGHTS`, by name."""
    out = {task: (plant.flights, plant.largest_ratio(plant.parameter_spread)) for task, plant in plants.items()}
    plant = plants["LightSail3DRealistic-v1"]
    config, largest = plant.config, plant.largest_ratio(plant.parameter_spread)
    for relativistic, diffracting in EXTRA_FLIGHTS:
        length = config.diffraction_length_m if diffracting else math.inf
        table = draw_flights(config.sail, 2.0 * config.beam_cutoff_s, relativistic, length, largest)
        out[f"relativistic={relativistic}, L0={length:.3g}"] = (table, largest)
    return out


def _read_four(arrays, ratio: jax.Array, t: jax.Array) -> jax.Array:
    """The four flight reads (4,) of one pair."""
    return jnp.stack([READS[q](arrays, ratio, t) for q in QUANTITIES])


@jax.jit
def _read_chunk(arrays, ratio: jax.Array, t: jax.Array) -> jax.Array:
    """The four reads (k, 4) of pairs (k,), the table an argument."""
    return jax.vmap(_read_four, in_axes=(None, 0, 0))(arrays, ratio, t)


@jax.jit
def _blend_chunk(arrays, scale: jax.Array) -> tuple[jax.Array, ...]:
    """``A_rad`` (k, 8, 8), ``B`` (k, 8, 4) and the push (k,) at scales (k,): ``B`` by its array, the
    others by name."""
    return tuple(jax.vmap(scale_blend, in_axes=(None, None, 0))(arrays, table, scale)
                 for table in ("radiation", arrays.inputs, "push"))


def _in_chunks(function, arrays, *columns: np.ndarray):
    """``function(arrays, *columns)`` :data:`CHUNK` rows at a time, the last chunk padded with ones: one
    compilation per table, whatever the number of reads."""
    count = len(columns[0])
    padded = [np.concatenate([np.asarray(c), np.ones(-count % CHUNK, np.asarray(c).dtype)]) for c in columns]
    parts = [function(arrays, *(c[i:i + CHUNK] for c in padded)) for i in range(0, count, CHUNK)]
    return jax.tree.map(lambda *chunks: np.concatenate(chunks)[:count], *parts)


def _reads(arrays, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The four reads (4, k) of pairs (k,), :data:`QUANTITIES` in order."""
    return _in_chunks(_read_chunk, arrays, ratio, t).T


_xla_log = jax.jit(jnp.log)


def _numpy_reads(read, with_xla_log: bool):
    """``read()`` (NumPy's methods), with ``np.log`` replaced by XLA's logarithm or not."""
    with pytest.MonkeyPatch.context() as patch:
        if with_xla_log:
            patch.setattr(np, "log", lambda x: np.asarray(_xla_log(np.asarray(x, np.float64))))
        return read()


def _exact_times(ratio: float, scaled: np.ndarray) -> np.ndarray:
    """Lab times ``t`` with ``ratio * t`` exactly ``scaled`` where one neighbour of ``scaled / ratio`` has it."""
    t = scaled / ratio
    for toward in (-np.inf, np.inf):
        near = np.nextafter(t, toward)
        t = np.where((ratio * t != scaled) & (ratio * near == scaled), near, t)
    return t


def _flight_pairs(table, largest: float) -> tuple[np.ndarray, np.ndarray]:
    """Random pairs over the valid range, and pairs exactly at every flight's nodes and kink times (and
    their neighbours) at its own ratio, at the nominal ratio and at the range's ends."""
    rng = np.random.default_rng(7)
    end = table.nominal.duration_s
    ratio = np.exp(rng.uniform(-math.log(largest), math.log(largest), RANDOM))
    t = rng.uniform(0.0, 1.0, RANDOM) * end / ratio
    ratios, times = [ratio, [1.0, largest, 1.0 / largest]], [t, [end, end / largest, end * largest]]
    nodes, kinks = table.table._nodes[..., 0], table.table.kink_times
    for row, log_ratio in enumerate(table.log_ratios):
        marks = np.concatenate([nodes[row], kinks[row]])
        marks = np.concatenate([marks, np.nextafter(marks, -np.inf), np.nextafter(marks, np.inf)])
        marks = marks[(marks >= 0) & (marks <= end)]
        for r in (math.exp(log_ratio), 1.0):
            ratios.append(np.full(marks.shape, r))
            times.append(_exact_times(r, marks))
    return np.concatenate(ratios), np.concatenate(times)


def _assert_read(name: str, got: np.ndarray, read, bound) -> None:
    """``got`` is ``read()`` with XLA's logarithm to the bit and with NumPy's within ``bound`` (a function of
    NumPy's read); without the exact XLA flag, within ``bound`` or 1e-14 relative of NumPy's."""
    want = _numpy_reads(read, with_xla_log=False)
    limit = bound(want)
    if EXACT:
        np.testing.assert_array_equal(got, _numpy_reads(read, with_xla_log=True), err_msg=name)
    else:
        limit = np.maximum(limit, 1e-14 * np.abs(want))
    excess = np.abs(got - want) / np.maximum(limit, 1e-300)
    assert np.all(excess <= 1.0), f"{name}: {np.max(excess)} times the bound"


def test_flight_reads_are_numpys(flights: dict) -> None:
    """Speed, power factor, distance and beam scale of every flight table at random pairs and its nodes."""
    for name, (table, largest) in flights.items():
        ratio, t = _flight_pairs(table, largest)
        got = _reads(flight_arrays(table), ratio, t)
        for quantity, read in zip(QUANTITIES, got):
            _assert_read(f"{name} {quantity}", read, lambda: getattr(table, quantity)(ratio, t),
                         lambda want: FLIGHT_ULP * np.spacing(np.abs(want)))


def _mixed_entries(table, entries: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The largest magnitude (k, ...) of the entries ``_blend`` mixes at each scale, and of their neighbours
    (a logarithm an ulp apart can move a read at a grid point into the next interval)."""
    grid = table.log_scales[1:]
    low = np.clip(np.searchsorted(grid, np.log(scale), side="right") - 1, 0, grid.size - 2)
    index = np.where(np.log(scale) > 0.0, 1 + low, 0)
    return np.maximum.reduce([np.abs(entries[np.clip(index + k, 0, grid.size)]) for k in (-1, 0, 1, 2)])


def test_scale_blends_are_numpys(plants: dict) -> None:
    """``A_rad``, ``B`` and the push of every task's scale table at random scales, its grid points and their
    neighbours, ``s = 1`` and its top, and below 1 (the first entry)."""
    rng = np.random.default_rng(11)
    for task, plant in plants.items():
        table = plant.scales
        grid = np.exp(table.log_scales)
        scale = np.concatenate([np.exp(rng.uniform(0.0, math.log(table.top), RANDOM // 4)), grid,
                                np.nextafter(grid, 0.0), np.nextafter(grid[:-1], np.inf),
                                [1.0, np.nextafter(1.0, np.inf), table.top, 0.5, 1e-300]])
        reads = (lambda: table.at(scale)[0], lambda: table.at(scale)[1], lambda: table.push_at(scale))
        entries = (table._radiation, table._inputs, table._push)
        for name, read, grid_entries, got in zip(("radiation", "inputs", "push"), reads, entries,
                                                 _in_chunks(_blend_chunk, scale_arrays(table), scale)):
            shape = (-1,) + (1,) * (grid_entries.ndim - 1)
            mixed = _mixed_entries(table, grid_entries, scale) / np.maximum(scale, 1.0).reshape(shape) ** 2
            _assert_read(f"{task} {name}", got, read, lambda want: SCALE_BOUND * mixed)


def test_reads_out_of_range_are_nan_where_numpy_raises(plants: dict) -> None:
    """Past the tabled flight and past the scale table's top NumPy raises and JAX reads NaN (and at
    ``t < 0`` and ``r ≤ 0``, which NumPy reads without meaning); a ratio beyond the draws' range reads the end
    flight (NumPy's clamp), a scale below 1 the first entry."""
    plant = plants["LightSail3DRealistic-v1"]
    table, scales = plant.flights, plant.scales
    arrays, end = flight_arrays(table), table.nominal.duration_s
    beyond = end * (1 + 1e-9)
    with pytest.raises(ValueError):
        table.speed(np.ones(2), np.array([1.0, beyond]))
    got = _reads(arrays, np.array([1.0, 1.0, -1.0, 0.0, 2.0, 0.5]), np.array([beyond, -1.0, -1.0, 1.0, end / 2, end]))
    assert np.all(np.isnan(got[:, :4]))
    want = [getattr(table, q)(np.array([2.0, 0.5]), np.array([end / 2, end])) for q in QUANTITIES]
    np.testing.assert_allclose(got[:, 4:], want, rtol=0 if EXACT else 1e-14)
    with pytest.raises(ValueError):
        scales.push_at(np.array([scales.top * (1 + 1e-9)]))
    push = _in_chunks(_blend_chunk, scale_arrays(scales), np.array([scales.top * (1 + 1e-9), 0.5]))[2]
    assert np.isnan(push[0]) and push[1] == scales.push_at(np.array([0.5]))[0] == scales._push[0]


def test_reads_under_jit_alone_and_under_vmap_with_a_shared_ratio_agree(plants: dict) -> None:
    """One pair under a bare ``jit``, the batch with the ratio shared by ``vmap`` (weights XLA would fold into
    other factors: the barrier of the mix), the batch with the table and the ratio closed over (divisions
    by constants XLA would turn into products with their reciprocals: ``arith.divide``) and the batch of
    pairs give the same numbers; ``scale_blend`` under ``jit`` takes the table's name as a static argument."""
    plant = plants["LightSailUncertain-v1"]
    table, arrays = plant.flights, flight_arrays(plant.flights)
    ratio, t = 1.3, np.linspace(0.0, table.nominal.duration_s / 1.3, 257)
    batch = _reads(arrays, np.full(t.shape, ratio), t)
    shared = jax.jit(jax.vmap(_read_four, in_axes=(None, None, 0)))(arrays, ratio, t).T
    # The table and the ratio closed over: constants of the computation.
    constant = jax.jit(jax.vmap(lambda time: _read_four(arrays, ratio, time)))(t).T
    alone = jax.jit(_read_four)
    single = np.stack([alone(arrays, ratio, s) for s in t[::32]], axis=1)
    for got, want in ((shared, batch), (constant, batch), (single, batch[:, ::32])):
        np.testing.assert_allclose(got, want, rtol=0 if EXACT else 1e-14, atol=0)
    scales, blend = scale_arrays(plant.scales), jax.jit(scale_blend, static_argnums=1)
    by_array = jax.jit(scale_blend)(scales, scales.radiation, 3.0)
    np.testing.assert_array_equal(blend(scales, "radiation", 3.0), by_array)
    np.testing.assert_array_equal(_in_chunks(_blend_chunk, scales, np.array([3.0]))[0][0], by_array)


def test_float32_reads_are_within_single_precision(plants: dict) -> None:
    """In float32 the reads are NumPy's float64 ones at the rounded inputs within 1e-6 relative (flights,
    measured 5e-7) and 3e-6 of a matrix's largest entry (scales, measured 1.1e-6)."""
    plant = plants["LightSail3DRealistic-v1"]
    table, largest = plant.flights, plant.largest_ratio(plant.parameter_spread)
    rng = np.random.default_rng(3)
    ratio = np.exp(rng.uniform(-math.log(largest), math.log(largest), 4096)).astype(np.float32)
    t = (rng.uniform(0.0, 0.999, 4096) * table.nominal.duration_s / ratio).astype(np.float32)
    got = _reads(flight_arrays(table, jnp.float32), ratio, t)
    for quantity, read in zip(QUANTITIES, got):
        want = getattr(table, quantity)(ratio.astype(float), t.astype(float))
        np.testing.assert_allclose(read, want, rtol=1e-6, atol=1e-6 * np.max(np.abs(want)), err_msg=quantity)
    scales = plant.scales
    scale = np.exp(rng.uniform(0.0, math.log(0.999 * scales.top), 1024)).astype(np.float32)
    got = _in_chunks(_blend_chunk, scale_arrays(scales, jnp.float32), scale)[0]
    want = scales.at(scale.astype(float))[0]
    largest_entry = np.abs(want).max(axis=(1, 2), keepdims=True)
    assert np.all(np.abs(got - want) <= 3e-6 * largest_entry)
