"""The compiled window step over N environments: the one implementation of its logic.

Clip and scale of the actions, the command ring and the delayed command (:func:`arrived_command`),
the beam jitter, the push noise (Horner over the push expansion's rows of ``PlantParams.step``), the
random impacts, the exact step, the plant's declared divergence rule, the envelope, the reward,
the termination and the observation. The coast after the window and the resets' physics (the
parameter draws, the pre-control coast) stay in NumPy (:mod:`sail_env.core.episode`).

Every kernel takes the :class:`~sail_env.core.state.EpisodeState`'s buffers (``floats``, ``ints``,
``layout``), ``consts`` (the action scales (m), the state scales (n), the sensor noise (n), the
push noise) and the plant's arrays (``steps`` (K, P·n, c), ``envelope`` (K, R·c, S): the look-ahead
tables transposed (``EpisodeCore.envelope_tables``), ``limits`` (K, G); K = 1 when every environment
shares the model). The caller allocates the outputs and the scratch (:func:`scratch`):
the kernels allocate nothing, and are compiled without reference counting (:data:`sail_env.jit.kernel`).

The step takes the environments in blocks of :data:`BLOCK`, each stage over the whole block. The
costliest stage, the envelope (:func:`_peak_speeds`), runs across the block's environments in its
inner loop when at least :data:`_FEW` share one table, passed as one (R·c, S) table
(:func:`shared_table`): LLVM vectorises that loop. With a table per environment (the tables do not fit
the cache across a block) or a few environments, the tables come as (K, R·c, S) and the envelope runs
one environment at a time, over the samples. The choice is the table's number of dimensions, a
type: each compiled step holds only its own path (~1.5 s less compile for a task that never runs
the other). Either way every environment's arithmetic is a scalar
step's, in the same order: a batch gives each environment's numbers to the last bit, whatever N is.
Scratch is indexed by two subscripts, never sliced per environment (a view costs two atomic
reference counts) and never by ``s·B + b`` (LLVM cannot drop that index's negative-index check, so
the accesses would not look consecutive); copies are loops, not slices (a slice's copy machinery
costs seconds of compile).
"""

from __future__ import annotations

import math

import numpy as np

from sail_env.core.delay import arrived_command
from sail_env.jit import inlined, kernel
from sail_env.core.reward import DIVERGENCE_PENALTY, log_ratio_of
from sail_env.core.state import Slot

# Numba's cache follows this file alone: the line below (tests/test_numba_cache.py) changes it when
# a file whose code or constants its compiled functions take in changes, so that they compile again.
# compiled in: sail_env/core/delay.py sail_env/core/reward.py sail_env/core/state.py sail_env/jit.py sail_env/physics/pointing.py sha256:585df32ab16a526e

OBSERVATION_LIMIT = 1e3
#: Environments a step takes together through each stage (their scratch stays in the L1 cache).
BLOCK = 32
#: Below this many environments (or with a table per environment) the envelope runs one environment
#: at a time; from it on, with one shared table, across the block (:func:`shared_table`).
_FEW = 4

# The layout's entries as plain integers (compile-time constants in the kernels).
_N, _NS, _NI, _NC, _NP, _NR, _NJ, _NIMP = (int(s) for s in (Slot.ENVS, Slot.STATES, Slot.INPUTS, Slot.COLUMNS,
                                                                Slot.POWERS, Slot.SPEED_ROWS,
                                                                Slot.JITTERED, Slot.IMPACTS))
_T, _CR, _SR, _H, _WIN, _PUSHED, _SENSED, _POWER, _G, _D, _K = (
    int(s) for s in (Slot.DELAY_LENGTH, Slot.COMMAND_RING, Slot.STATE_RING, Slot.HISTORY, Slot.WINDOW, Slot.PUSHED,
                     Slot.SENSED, Slot.POWER_INPUT, Slot.GROUPS, Slot.OBSERVATION, Slot.NORMALS))
_OJN, _OPN, _OSN, _OIN = (int(s) for s in (Slot.JITTER_NORMALS, Slot.PUSH_NORMALS, Slot.SENSOR_NORMALS,
                                           Slot.IMPACT_NORMALS))
_X, _LAST, _APPLIED, _CUT, _SPEED, _REWARD, _ENV, _CMDS, _HIST, _NORM, _JSTD, _ICNT, _ISTD = (
    int(s) for s in (Slot.X, Slot.LAST_COMMAND, Slot.APPLIED, Slot.CUTOFF, Slot.SPEED_AT_CUTOFF, Slot.REWARD,
                     Slot.ENVELOPE, Slot.COMMANDS, Slot.STATE_HISTORY, Slot.NORMAL_BLOCK, Slot.JITTER_STD,
                     Slot.IMPACT_COUNTS, Slot.IMPACT_STD))
_STEP, _FIN, _TERM, _DIV, _LAG, _DELAY, _TABLES = (
    int(s) for s in (Slot.STEP, Slot.FINISHED, Slot.TERMINATED, Slot.DIVERGED, Slot.LAG0, Slot.DELAY, Slot.TABLES))
_FREC, _IREC = int(Slot.FLOAT_RECORD), int(Slot.INT_RECORD)


@inlined
def _fl(layout: np.ndarray, slot: int, i: int) -> int:
    """Where environment ``i``'s field ``slot`` starts in the float buffer (one record per environment:
    its fields side by side, so a step reads a few neighbouring cache lines, not one per field)."""
    return i * layout[_FREC] + layout[slot]


@inlined
def _it(layout: np.ndarray, slot: int, i: int) -> int:
    """Where environment ``i``'s field ``slot`` starts in the integer buffer."""
    return i * layout[_IREC] + layout[slot]


@inlined
def _typed(value: int) -> int:
    """``value`` as a plain int64. A constant passed to a compiled function is typed as its literal,
    and the function is compiled once more for that value (~0.6 s for :func:`_physics`)."""
    return np.int64(value)


@kernel
def _applied(i: int, step: int, newest: int, work: np.ndarray, b: int, floats: np.ndarray, ints: np.ndarray,
             layout: np.ndarray) -> None:
    """Write into rows n … n + m - 1 of column ``b`` of ``work`` (the inputs' rows of :func:`_physics`)
    the command acting on environment ``i`` during ``step`` (zero before any arrives)."""
    n, m, ring = layout[_NS], layout[_NI], layout[_CR]
    sent = arrived_command(step, ints[_it(layout, _DELAY, i) + step], newest)
    base = _fl(layout, _CMDS, i) + (sent % ring) * m
    for c in range(m):
        work[n + c, b] = floats[base + c] if sent >= 0 else 0.0


@kernel
def _physics(block: np.ndarray, count: int, work: np.ndarray, floats: np.ndarray, layout: np.ndarray,
             consts: np.ndarray, steps: np.ndarray) -> None:
    """One plant step of environments ``block[0, :count]`` (their states in ``floats``, updated in
    place) with the per-step noise of noise steps ``block[1, :count]``. Column ``b`` of ``work``
    (:func:`_work`) holds environment ``b``'s inputs in rows n … c - 1 (m, and 1 for a constant
    term; the jitter is added there); the rest of it is scratch. ``steps`` is (K, P·n, c), one
    environment at a time, or one shared (P·n, c) model (:func:`shared_table`): then each sum runs
    across the block (independent sums, which LLVM vectorises; one environment's sums form a chain
    of dependent additions: 110 of 500 ns of a ``LightSail3D-v0`` step at N = 1024, 2026-12-03)."""
    n, cols, powers = layout[_NS], layout[_NC], layout[_NP]
    result, eps, total = cols, cols + n, cols + n + 2  # rows of work
    jittered, pushed, power, impacts = layout[_NJ], layout[_PUSHED] == 1, layout[_POWER], layout[_NIMP]
    for b in range(count):
        i, column = block[0, b], block[1, b]
        x0, normals = _fl(layout, _X, i), _fl(layout, _NORM, i)
        for k in range(n):
            work[k, b] = floats[x0 + k]
        if jittered:
            std = floats[_fl(layout, _JSTD, i) + column]
            for j in range(jittered):
                work[n + layout[_TABLES + j], b] += std * floats[normals + layout[_OJN] + column * jittered + j]
        e = consts[layout[_NI] + 2 * n] * floats[normals + layout[_OPN] + column] if pushed else 0.0
        if power >= 0:
            e = (1.0 + work[n + power, b]) * (1.0 + e) - 1.0 if pushed else work[n + power, b]
        work[eps, b] = e
    # Horner's scheme in ε over the push expansion's rows, highest power first; each sum from 0 over
    # the columns in order, so both paths give every environment the same bits.
    if steps.ndim == 2:
        for r in range(n):
            for p in range(powers - 1, -1, -1):
                for b in range(count):
                    work[total, b] = 0.0
                for k in range(cols):
                    coefficient = steps[p * n + r, k]
                    for b in range(count):
                        work[total, b] += coefficient * work[k, b]
                for b in range(count):
                    later = work[total, b] + work[eps, b] * work[result + r, b]
                    work[result + r, b] = work[total, b] if p == powers - 1 else later
    else:
        for b in range(count):
            model = block[0, b] if steps.shape[0] > 1 else 0
            for r in range(n):
                for p in range(powers - 1, -1, -1):
                    dot = 0.0
                    for k in range(cols):
                        dot += steps[model, p * n + r, k] * work[k, b]
                    work[result + r, b] = dot if p == powers - 1 else dot + work[eps, b] * work[result + r, b]
    for b in range(count):
        i, column = block[0, b], block[1, b]
        x0 = _fl(layout, _X, i)
        for r in range(n):
            floats[x0 + r] = work[result + r, b]
        if impacts:
            count_root = math.sqrt(floats[_fl(layout, _ICNT, i) + column])
            normals = _fl(layout, _NORM, i) + layout[_OIN] + column * impacts
            for j in range(impacts):
                kick = count_root * floats[_fl(layout, _ISTD, i) + j]
                floats[x0 + layout[_TABLES + jittered + j]] += kick * floats[normals + j]


@kernel
def _diverged(i: int, floats: np.ndarray, layout: np.ndarray, limits: np.ndarray) -> bool:
    """The plant's declared rule: the norm of each divergence group's rows beyond its limit (NaN too)."""
    x0, jitter, impacts = _fl(layout, _X, i), layout[_NJ], layout[_NIMP]
    model = i if limits.shape[0] > 1 else 0
    groups = _TABLES + jitter + impacts
    for g in range(layout[_G]):
        first, second = layout[groups + 2 * g], layout[groups + 2 * g + 1]
        size = abs(floats[x0 + first]) if second < 0 else math.hypot(floats[x0 + first], floats[x0 + second])
        if not size <= limits[model, g]:
            return True
    return False


@kernel
def _peak_speed(work: np.ndarray, b: int, cols: int, envelope: np.ndarray, model: int, speed_rows: int,
                sums: np.ndarray) -> float:
    """Largest lateral speed [m/s] over look-ahead table ``model`` of ``envelope`` (the norm of its
    velocity rows) from rows 0 … c - 1 of column ``b`` of ``work``: the state and the input held
    (:func:`sail_env.physics.pointing.peak_speed`). The tables (K, R·c, S) are transposed, so that
    the sums run over all samples at once (each sample's own sum, in the same order); ``sums`` is
    scratch (2 S: the speeds, then their norms)."""
    samples = envelope.shape[2]
    for r in range(speed_rows):
        for s in range(samples):
            sums[s] = 0.0
        for k in range(cols):
            value = work[k, b]
            row = r * cols + k
            for s in range(samples):
                sums[s] += envelope[model, row, s] * value
        if speed_rows == 1:
            for s in range(samples):
                sums[samples + s] = abs(sums[s])
        elif r == 0:
            for s in range(samples):
                sums[samples + s] = sums[s] * sums[s]
        else:
            for s in range(samples):
                sums[samples + s] += sums[s] * sums[s]
    best = sums[samples]
    for s in range(1, samples):
        if sums[samples + s] > best:
            best = sums[samples + s]
    return math.sqrt(best) if speed_rows > 1 else best


@kernel
def _peak_speeds(block: np.ndarray, count: int, work: np.ndarray, cols: int, target: int, envelope: np.ndarray,
                 speed_rows: int, sums: np.ndarray) -> None:
    """:func:`_peak_speed` of environments ``block[0, :count]`` into row ``target`` of ``work``, their
    states and held inputs in its rows 0 … c - 1; ``sums`` is scratch (2 S B). ``envelope`` is
    (K, R·c, S), one environment at a time, or one shared (R·c, S) table: then every sum runs across
    the block instead (the same sums in the same order). The branch is on the type, so it is
    compiled away."""
    samples, width = envelope.shape[-1], work.shape[1]
    if envelope.ndim == 3:
        for b in range(count):
            model = block[0, b] if envelope.shape[0] > 1 else 0
            work[target, b] = _peak_speed(work, b, cols, envelope, model, speed_rows, sums)
        return
    # The speeds (S, B), then their norms (S, B): indexed by two subscripts, never by s·B + b, whose
    # negative-index check LLVM cannot drop (the accesses would then not be consecutive).
    grid = sums[:2 * samples * width].reshape((2 * samples, width))
    for r in range(speed_rows):
        for s in range(samples):
            for b in range(count):
                grid[s, b] = 0.0
        for k in range(cols):
            row = r * cols + k
            for s in range(samples):
                coefficient = envelope[row, s]
                for b in range(count):
                    grid[s, b] += coefficient * work[k, b]
        for s in range(samples):
            for b in range(count):
                if speed_rows == 1:
                    grid[samples + s, b] = abs(grid[s, b])
                elif r == 0:
                    grid[samples + s, b] = grid[s, b] * grid[s, b]
                else:
                    grid[samples + s, b] += grid[s, b] * grid[s, b]
    for b in range(count):
        work[target, b] = grid[samples, b]
    for s in range(1, samples):
        for b in range(count):
            norm, best = grid[samples + s, b], work[target, b]
            work[target, b] = norm if norm > best else best  # a select, not a branch: it vectorises
    if speed_rows > 1:
        for b in range(count):
            work[target, b] = math.sqrt(work[target, b])


@kernel
def _observe(i: int, step: int, out: np.ndarray, row: int, floats: np.ndarray, ints: np.ndarray, layout: np.ndarray,
             consts: np.ndarray) -> None:
    """Fill row ``row`` of ``out`` (·, D) float32 with environment ``i``'s observation at ``step``: the (delayed, noisy)
    state over its scales, the progress through the window, the commands sent, newest first."""
    n, m, window = layout[_NS], layout[_NI], layout[_WIN]
    if layout[_T]:
        shown = max(step - ints[_it(layout, _DELAY, i) + step] + ints[_it(layout, _LAG, i)], 0)
        source = _fl(layout, _HIST, i) + (shown % layout[_SR]) * n
    else:
        source = _fl(layout, _X, i)
    sensed = layout[_SENSED] == 1
    noise = _fl(layout, _NORM, i) + layout[_OSN] + step * n
    limit = OBSERVATION_LIMIT
    for k in range(n):
        value = floats[source + k]
        if sensed:
            value = value + consts[m + n + k] * floats[noise + k]
        out[row, k] = min(max(value / consts[m + k], -limit), limit)
    out[row, n] = 2.0 * step / window - 1.0
    ring = layout[_CR]
    for h in range(layout[_H]):
        sent = step - 1 - h
        base = _fl(layout, _CMDS, i) + (sent % ring) * m
        for c in range(m):
            value = floats[base + c] / consts[c] if sent >= 0 else 0.0
            out[row, n + 1 + h * m + c] = min(max(value, -limit), limit)


@kernel
def observe(index: np.ndarray, out: np.ndarray, floats: np.ndarray, ints: np.ndarray, layout: np.ndarray,
            consts: np.ndarray) -> None:
    """Observations (k, D) of environments ``index`` at their current step."""
    for row in range(index.shape[0]):
        i = index[row]
        _observe(i, ints[_it(layout, _STEP, i)], out, row, floats, ints, layout, consts)


def scratch(layout: np.ndarray, samples: int, envs: int) -> tuple[np.ndarray, np.ndarray]:
    """The kernels' scratch for ``envs`` environments (the kernels allocate nothing,
    :data:`sail_env.jit.kernel`), blocks of B = min(``envs``, :data:`BLOCK`): ``block`` (2, B) their
    indices and noise steps; ``pad`` ((c + n + 3 + max(2 S, 1)) B,) ``work`` (:func:`_work`), then
    the envelope's sums. Zeros: the shared plant step's Horner loop reads a row before its first
    write (the value is then discarded, but never an uninitialised NaN)."""
    width = min(envs, BLOCK)
    rows = int(layout[Slot.COLUMNS]) + int(layout[Slot.STATES]) + 3
    return np.zeros((2, width), np.int64), np.zeros((rows + max(2 * samples, 1)) * width)


@inlined
def _work(layout: np.ndarray, block: np.ndarray, pad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``pad`` (:func:`scratch`) as ``work`` (c + n + 3, B): the physics' inputs and states, its
    results, ε, the peak speed and a sum (the plant step's, then the reward) of each of the block's
    environments; and ``sums``, the rest."""
    width = block.shape[1]
    size = (layout[_NC] + layout[_NS] + 3) * width
    return pad[:size].reshape((layout[_NC] + layout[_NS] + 3, width)), pad[size:]


def shared_table(tables: np.ndarray, envs: int) -> np.ndarray:
    """A plant table (K, ·, ·) as :func:`step` takes it for ``envs`` environments (the envelope's
    (K, R·c, S), the step's (K, P·n, c)): the shared table alone when at least :data:`_FEW`
    environments share it, so that its sums run across each block; else unchanged."""
    return tables[0] if tables.shape[0] == 1 and envs >= _FEW else tables


@kernel
def step(action: np.ndarray, out: np.ndarray, floats: np.ndarray, ints: np.ndarray, layout: np.ndarray,
         consts: np.ndarray, steps: np.ndarray, envelope: np.ndarray, limits: np.ndarray, block: np.ndarray,
         pad: np.ndarray) -> int:
    """Advance every environment one control step with ``action`` (N, m) in [-1, 1] (clipped): the
    state's fields and ``out`` (N, D) the observations. Returns how many episodes terminated (their
    scoring is the caller's); nothing changes and it returns -1 if an action is not finite, -2 if an
    episode has finished (it needs a reset). Environments go in blocks of :data:`BLOCK`, each stage
    over the whole block (:func:`_physics`, :func:`_peak_speeds`); ``steps`` and ``envelope`` are
    the tables as :func:`shared_table` gives them; ``block`` and ``pad`` the :func:`scratch`."""
    envs, n, m, cols = layout[_N], layout[_NS], layout[_NI], layout[_NC]
    for i in range(envs):
        if ints[_it(layout, _FIN, i)]:
            return -2
        for c in range(m):
            if not math.isfinite(action[i, c]):
                return -1
    width = block.shape[1]
    work, sums = _work(layout, block, pad)
    speed, reward = cols + n + 1, cols + n + 2  # the rows of work that receive the peak speeds and the rewards
    delayed = layout[_T] > 0
    ring, window = layout[_CR], layout[_WIN]
    ended = 0
    for first in range(0, envs, width):
        count = min(width, envs - first)
        for b in range(count):
            i = first + b
            now = ints[_it(layout, _STEP, i)]
            block[0, b], block[1, b] = i, now + ints[_it(layout, _LAG, i)]
            for c in range(m):
                command = min(max(action[i, c], -1.0), 1.0) * consts[c]
                floats[_fl(layout, _LAST, i) + c] = command
                if delayed:
                    floats[_fl(layout, _CMDS, i) + (now % ring) * m + c] = command
                work[n + c, b] = command
            if delayed:
                _applied(i, now, now, work, b, floats, ints, layout)
            for c in range(m):
                floats[_fl(layout, _APPLIED, i) + c] = work[n + c, b]
            if cols > n + m:
                work[n + m, b] = 1.0  # the constant term's input
        _physics(block, count, work, floats, layout, consts, steps)
        for b in range(count):  # the state and the applied input without the jitter: what the envelope holds
            i = first + b
            x0 = _fl(layout, _X, i)
            for k in range(n):
                work[k, b] = floats[x0 + k]
            for c in range(m):
                work[n + c, b] = floats[_fl(layout, _APPLIED, i) + c]
            if cols > n + m:
                work[n + m, b] = 1.0
        _peak_speeds(block, count, work, cols, speed, envelope, layout[_NR], sums)
        for b in range(count):  # the envelopes, then the rewards: no call in the loop, so it vectorises
            work[speed, b] = work[speed, b] / floats[_fl(layout, _SPEED, block[0, b])]
            work[reward, b] = -log_ratio_of(work[speed, b]) / window
        for b in range(count):
            i = first + b
            now = ints[_it(layout, _STEP, i)] + 1
            ints[_it(layout, _STEP, i)] = now
            x0 = _fl(layout, _X, i)
            if delayed:
                target = _fl(layout, _HIST, i) + ((now + ints[_it(layout, _LAG, i)]) % layout[_SR]) * n
                for k in range(n):
                    floats[target + k] = floats[x0 + k]
            diverged = _diverged(i, floats, layout, limits)
            floats[_fl(layout, _ENV, i)] = work[speed, b]
            terminated = diverged or now >= window
            floats[_fl(layout, _REWARD, i)] = DIVERGENCE_PENALTY if diverged else work[reward, b]
            ints[_it(layout, _TERM, i)] = terminated
            ints[_it(layout, _DIV, i)] = diverged
            if terminated:
                ints[_it(layout, _FIN, i)] = 1
                ended += 1
            _observe(i, now, out, i, floats, ints, layout, consts)
    return ended


@kernel
def pre_control(index: np.ndarray, floats: np.ndarray, ints: np.ndarray, layout: np.ndarray, consts: np.ndarray,
                steps: np.ndarray, block: np.ndarray, pad: np.ndarray) -> None:
    """The ``lag0`` steps before control of environments ``index`` (light delay), beam off, each
    state kept in the state ring (the first delayed observations show them); ``block`` and ``pad``
    the :func:`scratch`."""
    n, m, cols = layout[_NS], layout[_NI], layout[_NC]
    one = _typed(1)
    work, _ = _work(layout, block, pad)
    for row in range(index.shape[0]):
        i = index[row]
        x0 = _fl(layout, _X, i)
        for s in range(ints[_it(layout, _LAG, i)]):
            block[0, 0], block[1, 0] = i, s
            for c in range(cols - n):
                work[n + c, 0] = 1.0 if c == m else 0.0  # the beam off (and the constant term's 1)
            _physics(block, one, work, floats, layout, consts, steps)
            target = _fl(layout, _HIST, i) + ((s + 1) % layout[_SR]) * n
            for k in range(n):
                floats[target + k] = floats[x0 + k]


@kernel
def in_flight(index: np.ndarray, x: np.ndarray, reached: np.ndarray, floats: np.ndarray, ints: np.ndarray,
              layout: np.ndarray, consts: np.ndarray, steps: np.ndarray, block: np.ndarray, pad: np.ndarray) -> None:
    """After the window of environments ``index``: step each on until its last command has arrived
    (light delay). ``x`` (k, n) receives the states and ``reached`` (k,) the steps; the state buffer
    is left as the window ended; ``block`` and ``pad`` the :func:`scratch`."""
    n, m, cols, window = layout[_NS], layout[_NI], layout[_NC], layout[_WIN]
    zero, one = _typed(0), _typed(1)
    work, _ = _work(layout, block, pad)
    last = window - 1
    for row in range(index.shape[0]):
        i = index[row]
        x0 = _fl(layout, _X, i)
        for k in range(n):
            x[row, k] = floats[x0 + k]  # the state as the window ended: put back below
        now = ints[_it(layout, _STEP, i)]
        while now - ints[_it(layout, _DELAY, i) + now] < last:
            _applied(i, now, last, work, zero, floats, ints, layout)
            if cols > n + m:
                work[n + m, 0] = 1.0
            block[0, 0], block[1, 0] = i, now + ints[_it(layout, _LAG, i)]
            _physics(block, one, work, floats, layout, consts, steps)
            now += 1
        for k in range(n):
            x[row, k], floats[x0 + k] = floats[x0 + k], x[row, k]
        reached[row] = now


@kernel
def peak_speeds(index: np.ndarray, x: np.ndarray, u: np.ndarray, speed_rows: int, envelope: np.ndarray,
                out: np.ndarray, layout: np.ndarray, block: np.ndarray, pad: np.ndarray) -> None:
    """:func:`_peak_speed` of environments ``index`` at states ``x`` (k, n) with inputs ``u`` (k, c - n),
    a block of the :func:`scratch` at a time."""
    n, cols, k = x.shape[1], x.shape[1] + u.shape[1], index.shape[0]
    work, sums = _work(layout, block, pad)
    width = block.shape[1]
    for first in range(0, k, width):
        count = min(width, k - first)
        for b in range(count):
            block[0, b] = index[first + b]
            for j in range(cols):
                work[j, b] = x[first + b, j] if j < n else u[first + b, j - n]
        _peak_speeds(block, count, work, cols, cols, envelope, speed_rows, sums)
        for b in range(count):
            out[first + b] = work[cols, b]
