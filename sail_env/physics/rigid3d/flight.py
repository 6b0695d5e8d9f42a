"""The centred sail's axial flight: distance, speed, Doppler factor and spot widening over time
(docs/physics.md §5, §7, §12, §14).

The quantities that set the lateral dynamics along the flight — the push's Doppler factor
``(1−β)/(1+β)`` and the spot's widening ``max(1, D/L0)`` — and the distance ``D(t)`` that turns a
ground pointing angle into a spot offset are read from a table built once per task
(:class:`FlightTable`), hundreds of times an episode.

How the table is built. Up to the diffraction length the push is constant (``F₁``, the centred
sail's at rest), and the relativistic law ``d(γβ)/dt = k (1−β)/(1+β)``, ``k = F₁/(m c)``, has a
closed form: with the rapidity ``η`` (``γβ = sinh η``, ``(1−β)/(1+β) = e^{−2η}``) and
``ε = e^η − 1``, ``k t = ε + ε²/2 + ε³/6`` and ``D = (c/2k) ε² (1 + ε/3)`` (written in ``ε`` so that
nothing cancels near rest). Beyond ``L0`` the push ``F(s)`` of the widened spot (:class:`PushLaw`)
changes along the flight and the law is integrated by the classical fourth-order Runge–Kutta rule
on the table's own grid, from the crossing time, which is a node (the push's derivative jumps
there). The push law and the step are compiled (:mod:`sail_env.jit`), in Python's order of
operations; a square is a product there, correctly rounded, where Python's ``x**2`` goes through the
C library's ``pow`` (1 ulp off at times, and library-dependent): measured against the Python build,
42 of the 158,544 entries of the 3D realistic task's table differ, by at most 4e-16 relative, and
its episodes are the same to the last bit. Every sum is a fixed-order loop or an element-wise NumPy
operation, never a BLAS call, so two BLAS kernels build the same table to the last bit (the DOP853
solution this replaces picked its steps by a BLAS norm and differed by 1.2e-9 between OpenBLAS
kernels, docs/physics.md §3). The
table is read by cubic Hermite interpolation of ``γβ`` and ``D`` with their exact derivatives at
the nodes; tested against DOP853 at ``rtol`` 1e-13 (``tests/physics/test_flight_table.py``).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from sail_env.jit import compiled
from sail_env.physics.memo import built_once
from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.relativity import diffraction_scale
from sail_env.physics.rigid3d.body import RigidSail
from sail_env.physics.rigid3d.config import RigidSailConfig

# Numba's cache follows this file alone: the line below (tests/test_numba_cache.py) changes it when
# a file whose code or constants its compiled functions take in changes, so that they compile again.
# compiled in: sail_env/jit.py sail_env/physics/constants.py sha256:f3bba43c153af2cd

#: Flights a :class:`DrawFlights` with diffraction integrates across the draws' range of ``F/m``.
DRAW_NODES = 9
#: Spacing [s] of the flight table's nodes (and the Runge–Kutta step beyond ``L0``). The flight
#: changes on the scale of ``c/a`` ~ 3,000 s before ``L0`` and ``D/V`` ~ 400 s beyond it, so cubic
#: Hermite interpolation is good to ~(h/400 s)⁴/384 ~ 1e-14 and RK4 to ~1e-14 over the flight
#: (measured: ``tests/physics/test_flight_table.py``).
TABLE_STEP_S = 0.5
#: Chebyshev points per piece of the push law :class:`PushLaw` (smooth in ``ln s`` within a piece).
PUSH_NODES = 32
#: Secant iterations that put a node where a hard beam edge meets the rim beyond ``L0``.
EDGE_ITERATIONS = 60


class PushLaw:
    """The centred sail's push in a spot widened by ``s ≥ 1``, relative to ``s = 1``: ``F(s)/F(1)``.

    ``s² F(s)/F(1)`` (the push at the spot's intensity of ``s = 1``: exactly 1 for a sail inside a
    uniform spot) is interpolated in ``ln s`` through :data:`PUSH_NODES` Chebyshev points of each
    piece between the scales where a hard beam edge meets the rim (:func:`scale_grid`), by the
    barycentric formula (Berrut & Trefethen 2004) summed in a fixed order.
    """

    def __init__(self, sail: RigidSail, top: float) -> None:
        from sail_env.physics.rigid3d.scales import scale_grid  # scales → damping → this module

        _, kinks = scale_grid(sail.config, top)
        self.edges = sorted({0.0, *kinks, math.log(max(top, 1.0 + 1e-9))})
        near = sail.centred_push(1.0, 1.0)
        count = PUSH_NODES
        # Chebyshev points of the second kind and their barycentric weights (−1)^j, halved at the ends.
        weights = [(-1.0) ** j * (0.5 if j in (0, count - 1) else 1.0) for j in range(count)]
        pieces = []
        for lo, hi in zip(self.edges[:-1], self.edges[1:]):
            nodes = [0.5 * (lo + hi) + 0.5 * (hi - lo) * math.cos(math.pi * j / (count - 1)) for j in range(count)]
            values = [math.exp(2.0 * x) * sail.centred_push(1.0, math.exp(x)) / near for x in nodes]
            pieces.append((hi, nodes, values))
        #: What the compiled functions read: each piece's upper end (P,), its nodes and values (P, count), the weights.
        self.tables = (np.array([p[0] for p in pieces]), np.array([p[1] for p in pieces]),
                       np.array([p[2] for p in pieces]), np.array(weights))

    def relative(self, scale: float) -> float:
        """``F(s)/F(1)``."""
        return _push_relative(scale, *self.tables)


@compiled
def _push_inside(log_scale: float, his: np.ndarray, nodes: np.ndarray, values: np.ndarray,
                 weights: np.ndarray) -> float:
    """``s² F(s)/F(1)`` at ``ln s = log_scale`` (≥ 0) from :class:`PushLaw`'s tables: the first piece
    whose upper end is at least ``log_scale`` (the last beyond), the barycentric sum over its nodes in order."""
    piece = his.shape[0] - 1
    for j in range(his.shape[0]):
        if log_scale <= his[j]:
            piece = j
            break
    numerator = denominator = 0.0
    for j in range(weights.shape[0]):
        gap = log_scale - nodes[piece, j]
        if gap == 0.0:
            return values[piece, j]
        numerator += weights[j] * values[piece, j] / gap
        denominator += weights[j] / gap
    return numerator / denominator


@compiled
def _push_relative(scale: float, his: np.ndarray, nodes: np.ndarray, values: np.ndarray, weights: np.ndarray) -> float:
    """:meth:`PushLaw.relative` from its tables."""
    return 1.0 if scale <= 1.0 else _push_inside(math.log(scale), his, nodes, values, weights) / scale**2


def _closed_form(k: float, t: np.ndarray, relativistic: bool) -> tuple[np.ndarray, ...]:
    """``(γβ, d(γβ)/dt, D, dD/dt)`` at times ``t`` under the constant push ``k = F/(m c)`` from rest."""
    c = SPEED_OF_LIGHT
    if not relativistic:
        return k * t, np.full_like(t, k), 0.5 * c * k * t**2, c * k * t
    # ε = e^η − 1 solves ε + ε²/2 + ε³/6 = k t: Newton from above (the cubic is convex for ε ≥ 0).
    target = k * t
    eps = target.copy()
    for _ in range(60):
        step = (eps + eps**2 / 2 + eps**3 / 6 - target) / (1.0 + eps + eps**2 / 2)
        eps = eps - step
        if np.all(np.abs(step) <= 1e-17 * np.maximum(eps, 1e-300)):
            break
    return _rapidity_state(k, eps)


def _rapidity_state(k: float, eps: np.ndarray) -> tuple[np.ndarray, ...]:
    """The relativistic constant-push state at ``ε = e^η − 1`` (see :func:`_closed_form`)."""
    c = SPEED_OF_LIGHT
    u = 1.0 + eps
    momentum = eps * (2.0 + eps) / (2.0 * u)  # sinh η
    beta = eps * (2.0 + eps) / (1.0 + u * u)  # tanh η
    return momentum, k / (u * u), (0.5 * c / k) * eps**2 * (1.0 + eps / 3.0), beta * c


def _crossing_time(k: float, length: float, relativistic: bool) -> float:
    """Time at which the constant-push flight reaches the distance ``length``."""
    c = SPEED_OF_LIGHT
    if not relativistic:
        return math.sqrt(2.0 * length / (c * k))
    # ε² (1 + ε/3) = 2 k L / c, then t = (ε + ε²/2 + ε³/6)/k.
    target = 2.0 * k * length / c
    eps = max(math.sqrt(target), 1e-300)
    for _ in range(100):
        step = (eps * eps * (1.0 + eps / 3.0) - target) / (2.0 * eps + eps * eps)
        eps -= step
        if abs(step) <= 1e-17 * eps:
            break
    return (eps + eps**2 / 2 + eps**3 / 6) / k


class _Rates:
    """``(d(γβ)/dt, dD/dt)`` beyond ``L0`` and the Runge–Kutta step (compiled: a table takes ~15,000
    steps; plain floats in a fixed order either way)."""

    def __init__(self, k: float, length: float, law: PushLaw, relativistic: bool) -> None:
        self.args = (k, length, relativistic, *law.tables)

    def __call__(self, momentum: float, distance: float) -> tuple[float, float]:
        return _rates(momentum, distance, *self.args)

    def rk4(self, momentum: float, distance: float, h: float) -> tuple[float, float]:
        """One classical Runge–Kutta step of ``h`` seconds."""
        return _rk4(momentum, distance, h, *self.args)


@compiled
def _rates(momentum: float, distance: float, k: float, length: float, relativistic: bool, his: np.ndarray,
           nodes: np.ndarray, values: np.ndarray, weights: np.ndarray) -> tuple[float, float]:
    push = k * _push_relative(distance / length, his, nodes, values, weights)
    if not relativistic:
        return push, SPEED_OF_LIGHT * momentum
    energy = math.sqrt(1.0 + momentum * momentum)
    return push / (energy + momentum) ** 2, SPEED_OF_LIGHT * momentum / energy


@compiled
def _rk4(momentum: float, distance: float, h: float, k: float, length: float, relativistic: bool, his: np.ndarray,
         nodes: np.ndarray, values: np.ndarray, weights: np.ndarray) -> tuple[float, float]:
    law = (k, length, relativistic, his, nodes, values, weights)
    p1, d1 = _rates(momentum, distance, *law)
    p2, d2 = _rates(momentum + 0.5 * h * p1, distance + 0.5 * h * d1, *law)
    p3, d3 = _rates(momentum + 0.5 * h * p2, distance + 0.5 * h * d2, *law)
    p4, d4 = _rates(momentum + h * p3, distance + h * d3, *law)
    return (momentum + h / 6.0 * (p1 + 2.0 * p2 + 2.0 * p3 + p4),
            distance + h / 6.0 * (d1 + 2.0 * d2 + 2.0 * d3 + d4))


class FlightTable:
    """Flights from rest under the push ``k = F₁/(m c)`` with diffraction lengths ``lengths`` (F,),
    tabled every :data:`TABLE_STEP_S` seconds up to ``duration_s`` (the module's method).

    Each flight's nodes are the uniform grid and, as extra nodes, the times it reaches ``L0`` and
    each scale where the push has a kink (``kink_times`` (F, K); beyond ``duration_s`` if never), so
    the interval of a time ``t`` is ``⌊t/h⌋`` plus the number of those times ``≤ t``.
    """

    def __init__(self, k: float, lengths: list[float], duration_s: float, relativistic: bool,
                 law: PushLaw | None) -> None:
        h = TABLE_STEP_S
        self.duration_s, self.relativistic, self.step = duration_s, relativistic, h
        uniform = h * np.arange(math.ceil(duration_s / h + 1e-9) + 1)
        kinks = [0.0] if law is None else [x for x in law.edges[:-1]]
        rows = [self._flight(k, length, uniform, kinks, relativistic, law) for length in lengths]
        self.times, self.momentum, self.momentum_rate, self.distance, self.distance_rate, self.kink_times = (
            np.array([row[i] for row in rows]) for i in range(6))
        # d²D/dt² = c dβ/dt = c d(γβ)/dt / γ³ (Newton: c dβ/dt).
        gamma3 = (1.0 + self.momentum**2) ** 1.5 if relativistic else 1.0
        self.distance_accel = SPEED_OF_LIGHT * self.momentum_rate / gamma3
        self._index()

    def _index(self) -> None:
        """The reads' view of the table: every node's quantities together (F, T, 6), contiguous."""
        self._nodes = np.ascontiguousarray(np.stack([self.times, self.momentum, self.momentum_rate, self.distance,
                                                     self.distance_rate, self.distance_accel], axis=-1))

    def __getstate__(self) -> dict:
        """The table without its view (a third of its file in the disk cache, physics/memo.py)."""
        return {k: v for k, v in vars(self).items() if k != "_nodes"}

    def __setstate__(self, state: dict) -> None:
        vars(self).update(state)
        self._index()

    @staticmethod
    def _flight(k: float, length: float, uniform: np.ndarray, kinks: list[float], relativistic: bool,
                law: PushLaw | None) -> tuple[np.ndarray, ...]:
        end = float(uniform[-1])
        crossing = _crossing_time(k, length, relativistic) if math.isfinite(length) else math.inf
        before = uniform[uniform < crossing]
        p, dp, d, dd = (list(a) for a in _closed_form(k, before, relativistic))
        times = list(before)
        kink_times = [end + 1.0 + i for i in range(len(kinks))]  # beyond the table: never reached
        if crossing < end:
            momentum, distance = (float(a[0]) for a in _closed_form(k, np.array([crossing]), relativistic)[::2])
            rates = _Rates(k, length, law, relativistic)
            t, targets = crossing, [length * math.exp(x) for x in kinks]
            kink_times[0] = crossing
            pending = 1
            nodes = [crossing, *uniform[uniform > crossing]]
            for i, node in enumerate(nodes):
                if i:
                    new = rates.rk4(momentum, distance, node - t)
                    if pending < len(targets) and new[1] >= targets[pending]:
                        # A hard edge meets the rim within the step: a node where it does.
                        lo, hi = 0.0, node - t
                        for _ in range(EDGE_ITERATIONS):
                            mid = 0.5 * (lo + hi)
                            short = rates.rk4(momentum, distance, mid)[1] < targets[pending]
                            lo, hi = (mid, hi) if short else (lo, mid)
                        edge = t + hi
                        momentum, distance = rates.rk4(momentum, distance, hi)
                        times.append(edge)
                        rate = rates(momentum, distance)
                        p.append(momentum), d.append(distance), dp.append(rate[0]), dd.append(rate[1])
                        kink_times[pending] = edge
                        pending += 1
                        t = edge
                        new = rates.rk4(momentum, distance, node - t)
                    momentum, distance, t = new[0], new[1], node
                rate = rates(momentum, distance)
                times.append(node)
                p.append(momentum), d.append(distance), dp.append(rate[0]), dd.append(rate[1])
        # Kinks never reached: extra nodes beyond the end keep every flight's row the same length.
        while len(times) < len(uniform) + len(kinks):
            times.append(times[-1] + 1.0)
            p.append(p[-1]), d.append(d[-1]), dp.append(dp[-1]), dd.append(dd[-1])
        return (np.array(times), np.array(p), np.array(dp), np.array(d), np.array(dd), np.array(kink_times))

    def read(self, row: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(γβ, D)`` of flights ``row`` (k,) at times ``t`` (k,) (:func:`_read_node`, compiled: one pass
        over the times, where NumPy made ~40 temporaries; the same arithmetic in the same order, so the
        same numbers to the last bit)."""
        t = np.ascontiguousarray(t, dtype=np.float64)
        momentum, distance = np.empty(t.shape), np.empty(t.shape)
        _read_nodes(self._nodes, self.kink_times, self.step, np.ascontiguousarray(row, dtype=np.int64), t,
                    momentum, distance)
        return momentum, distance

    def read_one(self, row: int, t: float) -> tuple[float, float]:
        """:meth:`read` of one flight at one time, in Python floats."""
        return _read_node(self._nodes, self.kink_times, self.step, row, t)


@compiled
def _read_node(nodes: np.ndarray, kink_times: np.ndarray, step: float, row: int, t: float) -> tuple[float, float]:
    """``(γβ, D)`` of flight ``row`` at time ``t``: the interval is ``⌊t/h⌋`` plus the kinks at or
    before ``t`` (:class:`FlightTable`), read by :func:`_hermite` from its two nodes."""
    index = np.int64(t * (1.0 / step))
    for column in range(kink_times.shape[1]):
        if kink_times[row, column] <= t:
            index += 1
    index = min(index, nodes.shape[1] - 2)
    return _hermite(t, nodes[row, index], nodes[row, index + 1])


@compiled
def _read_nodes(nodes: np.ndarray, kink_times: np.ndarray, step: float, row: np.ndarray, t: np.ndarray,
                momentum: np.ndarray, distance: np.ndarray) -> None:
    """:func:`_read_node` of flights ``row`` (k,) at times ``t`` (k,) into ``momentum`` and ``distance``."""
    for i in range(t.shape[0]):
        momentum[i], distance[i] = _read_node(nodes, kink_times, step, row[i], t[i])


@compiled
def _hermite(t: float, start: np.ndarray, end: np.ndarray) -> tuple[float, float]:
    """``(γβ, D)`` at ``t`` between two table nodes ``start`` and ``end`` (6,), each
    ``(time, γβ, d(γβ)/dt, D, dD/dt, d²D/dt²)``: ``γβ`` by cubic Hermite
    interpolation (value and rate at both nodes), ``D`` by quintic (with ``d²D/dt²``: exact for the
    ``t²`` and ``t³`` of the first seconds, where a cubic would be off by ~1e-9 of ``D``)."""
    width = end[0] - start[0]
    x = (t - start[0]) / width
    x2 = x * x
    x3 = x2 * x
    rest = (1.0 - x) * (1.0 - x)
    momentum = ((1.0 + 2.0 * x) * rest * start[1] + x2 * (3.0 - 2.0 * x) * end[1]
                + width * (x * rest * start[2] + x2 * (x - 1.0) * end[2]))
    far = x3 * (10.0 - 15.0 * x + 6.0 * x2)
    distance = ((1.0 - far) * start[3] + far * end[3]
                + width * ((x - 6.0 * x3 + 8.0 * x3 * x - 3.0 * x3 * x2) * start[4]
                           + (-4.0 * x3 + 7.0 * x3 * x - 3.0 * x3 * x2) * end[4])
                + width * width * (0.5 * x2 * rest * (1.0 - x) * start[5] + 0.5 * x3 * rest * end[5]))
    return momentum, distance


class Flight:
    """The flight of one sail design from rest (one row of a :class:`FlightTable`).

    Attributes:
        duration_s: Beam time covered (the cut-off).
        relativistic: ``True``: ``d(γβ)/dt`` with the Doppler factor; ``False``: Newton's
            ``dβ/dt = F/(m c)`` at the centred push (the planar model's flight).
        diffraction_length_m: ``L0``, beyond which the spot widens as ``D/L0``.
    """

    def __init__(self, duration_s: float, relativistic: bool, diffraction_length_m: float, table: FlightTable,
                 row: int) -> None:
        self.duration_s, self.relativistic, self.diffraction_length_m = duration_s, relativistic, diffraction_length_m
        self._table, self._row = table, row

    def _read(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(t, float)
        flat = np.atleast_1d(t).ravel()
        momentum, distance = self._table.read(np.full(flat.shape, self._row), flat)
        return momentum.reshape(t.shape), distance.reshape(t.shape)

    def momentum(self, t: np.ndarray | float) -> np.ndarray:
        """``γβ`` (``β`` when not relativistic) at lab time ``t``."""
        return self._read(t)[0]

    def distance(self, t: np.ndarray | float) -> np.ndarray:
        """``D(t)`` [m] from the laser."""
        return self._read(t)[1]

    def beta(self, t: np.ndarray | float) -> np.ndarray:
        return _beta(self.momentum(t), self.relativistic)

    def speed(self, t: np.ndarray | float) -> np.ndarray:
        """Axial speed ``Vz`` [m/s]: the denominator of the pointing angle."""
        return self.beta(t) * SPEED_OF_LIGHT

    def power_factor(self, t: np.ndarray | float) -> np.ndarray:
        """Doppler factor of every radiation force (1 when not relativistic)."""
        return _power_factor(self.momentum(t), self.relativistic)

    def beam_scale(self, t: np.ndarray | float) -> np.ndarray:
        """How much wider the spot is than at ``L0``."""
        return diffraction_scale(self.distance(t), self.diffraction_length_m)


def _beta(momentum, relativistic: bool):
    """``β`` of ``γβ`` (arrays or floats)."""
    return momentum / (1.0 + momentum * momentum) ** 0.5 if relativistic else momentum


def _power_factor(momentum, relativistic: bool):
    """``(1−β)/(1+β) = e^{−2η} = 1/(√(1+(γβ)²) + γβ)²`` (no cancellation near rest; arrays or floats)."""
    if not relativistic:
        return momentum * 0.0 + 1.0
    return 1.0 / ((1.0 + momentum * momentum) ** 0.5 + momentum) ** 2


def _pick_speed(momentum, distance, relativistic: bool):
    """The speed [m/s] of a table read ``(γβ, D)``."""
    return _beta(momentum, relativistic) * SPEED_OF_LIGHT


def _pick_power_factor(momentum, distance, relativistic: bool):
    """The Doppler power factor of a table read ``(γβ, D)``."""
    return _power_factor(momentum, relativistic)


def _pick_distance(momentum, distance):
    """The distance [m] of a table read ``(γβ, D)``."""
    return distance


def _table(sail: RigidSail, duration_s: float, relativistic: bool, lengths: list[float]) -> FlightTable:
    """The flights of ``sail`` with diffraction lengths ``lengths``, tabled to ``duration_s``."""
    for length in lengths:
        if not length > 0:
            raise ValueError(f"diffraction_length_m must be > 0, got {length}")
    k = sail.centred_push(1.0, 1.0) / (sail.mass * SPEED_OF_LIGHT)
    law = None
    if any(math.isfinite(length) for length in lengths):
        # Diffraction only lowers the push, so no flight goes farther than the constant push's.
        farthest = float(_closed_form(k, np.array([duration_s]), relativistic)[2][0])
        law = PushLaw(sail, 1.01 * farthest / min(lengths))
    return FlightTable(k, lengths, duration_s, relativistic, law)


def fly(sail: RigidSail, duration_s: float, relativistic: bool = True,
        diffraction_length_m: float = math.inf) -> Flight:
    """The centred sail's axial flight from rest over ``duration_s`` seconds (the module's method)."""
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s must be finite and > 0, got {duration_s}")
    table = _table(sail, duration_s, relativistic, [diffraction_length_m])
    return Flight(duration_s, relativistic, diffraction_length_m, table, 0)


class DrawFlights:
    """The flights of sails with ``r`` times the nominal sail's ``F/m`` (a parameter draw), for
    ``1/r_max ≤ r ≤ r_max``, all read at their own lab time ``t`` (docs/physics.md §14).

    Substituting ``τ = r t`` and ``D̃ = r D`` in the axial law turns the flight of ratio ``r`` into
    the nominal sail's with the diffraction length ``r L0``, read at ``τ``. Without diffraction
    that is the nominal flight itself (``q_r(t) = q(r t)``, ``D_r(t) = D(r t)/r``): exact. With
    diffraction the flights of :data:`DRAW_NODES` ratios equally spaced in ``ln r`` (the nominal one
    among them) are tabled, and each quantity at ``τ`` is interpolated linearly in ``ln r`` between
    the two nodes around the draw.
    """

    def __init__(self, sail: RigidSail, duration_s: float, relativistic: bool, diffraction_length_m: float,
                 largest_ratio: float) -> None:
        if not diffraction_length_m > 0:
            raise ValueError(f"diffraction_length_m must be > 0, got {diffraction_length_m}")
        count = DRAW_NODES if math.isfinite(diffraction_length_m) and largest_ratio > 1 else 1
        self.log_ratios = np.linspace(-math.log(largest_ratio), math.log(largest_ratio), count)
        self.diffraction_length_m = diffraction_length_m
        self.relativistic = relativistic
        lengths = [diffraction_length_m * math.exp(x) for x in self.log_ratios]
        duration = duration_s * largest_ratio
        self.table = _table(sail, duration, relativistic, lengths)
        self.flights = [Flight(duration, relativistic, length, self.table, j) for j, length in enumerate(lengths)]
        self.nominal = self.flights[count // 2]
        self._positions = np.arange(count, dtype=float)
        # Module functions, not lambdas: the table cache (physics/memo.py) stores functions by name.
        self._picks = {"speed": functools.partial(_pick_speed, relativistic=relativistic),
                       "power_factor": functools.partial(_pick_power_factor, relativistic=relativistic),
                       "distance": _pick_distance}

    def _both(self, ratio: np.ndarray, t: np.ndarray) -> tuple:
        """``(τ, rows, weights)``: the draws' flight times on the nominal clock and the two table rows
        (with their weights) around each draw's ``ln r``."""
        ratio, t = np.broadcast_arrays(np.atleast_1d(np.asarray(ratio, float)), np.asarray(t, float))
        scaled = (ratio * t).ravel()
        if np.any(scaled > self.nominal.duration_s * (1 + 1e-12)):
            raise ValueError(f"flight time {float(np.max(t))} s is beyond the tabled flight "
                             f"({self.nominal.duration_s} s at the nominal push)")
        if len(self.flights) == 1:
            return scaled, ratio.shape, np.zeros(scaled.shape, np.int64), None, None
        position = np.interp(np.log(ratio.ravel()), self.log_ratios, np.arange(len(self.flights)))
        low = np.minimum(position.astype(np.int64), len(self.flights) - 2)
        return scaled, ratio.shape, low, low + 1, position - low

    def _read(self, quantity: str, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        pick = self._picks[quantity]
        if np.size(ratio) == 1 and np.size(t) == 1:
            shape = np.broadcast_shapes(np.shape(np.atleast_1d(ratio)), np.shape(t))
            return np.full(shape, self._read_one(pick, np.asarray(ratio, float).item(), np.asarray(t, float).item()))
        scaled, shape, low, high, frac = self._both(ratio, t)
        below = pick(*self.table.read(low, scaled))
        if high is None:
            return below.reshape(shape)
        above = pick(*self.table.read(high, scaled))
        return ((1 - frac) * below + frac * above).reshape(shape)

    def _read_one(self, pick, ratio: float, t: float) -> float:
        """:meth:`_read` of one draw at one time in Python floats (the single environment's step)."""
        scaled = ratio * t
        if scaled > self.nominal.duration_s * (1 + 1e-12):
            raise ValueError(f"flight time {t} s is beyond the tabled flight ({self.nominal.duration_s} s at the "
                             f"nominal push)")
        if len(self.flights) == 1:
            return pick(*self.table.read_one(0, scaled))
        position = float(np.interp(math.log(ratio), self.log_ratios, self._positions))
        low = min(int(position), len(self.flights) - 2)
        frac = position - low
        below = pick(*self.table.read_one(low, scaled))
        above = pick(*self.table.read_one(low + 1, scaled))
        return (1 - frac) * below + frac * above

    def speed(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        return self._read("speed", ratio, t)

    def power_factor(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        return self._read("power_factor", ratio, t)

    def distance(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        return self._read("distance", ratio, t) / ratio

    def beam_scale(self, ratio: np.ndarray, t: np.ndarray) -> np.ndarray:
        return diffraction_scale(self.distance(ratio, t), self.diffraction_length_m)


@built_once
def draw_flights(sail: RigidSailConfig, duration_s: float, relativistic: bool, diffraction_length_m: float,
                 largest_ratio: float) -> DrawFlights:
    """The :class:`DrawFlights` of ``sail``, built once per process and shared read-only
    (:func:`~sail_env.physics.memo.built_once`)."""
    return DrawFlights(RigidSail(sail), duration_s, relativistic, diffraction_length_m, largest_ratio)
