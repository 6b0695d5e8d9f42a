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
shares the model). The caller allocates the outputs.
"""

from __future__ import annotations

import math

import numpy as np

from sail_env.core.delay import arrived_command
from sail_env.jit import compiled
from sail_env.core.reward import DIVERGENCE_PENALTY, log_ratio_of
from sail_env.core.state import Slot

OBSERVATION_LIMIT = 1e3

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


@compiled
def _fl(layout: np.ndarray, slot: int, i: int) -> int:
    """Where environment ``i``'s field ``slot`` starts in the float buffer (one record per environment:
    its fields side by side, so a step reads a few neighbouring cache lines, not one per field)."""
    return i * layout[_FREC] + layout[slot]


@compiled
def _it(layout: np.ndarray, slot: int, i: int) -> int:
    """Where environment ``i``'s field ``slot`` starts in the integer buffer."""
    return i * layout[_IREC] + layout[slot]


@compiled
def _applied(i: int, step: int, newest: int, u: np.ndarray, floats: np.ndarray, ints: np.ndarray,
             layout: np.ndarray) -> None:
    """Write into ``u[:m]`` the command acting on environment ``i`` during ``step`` (zero before any arrives)."""
    m, ring = layout[_NI], layout[_CR]
    sent = arrived_command(step, ints[_it(layout, _DELAY, i) + step], newest)
    base = _fl(layout, _CMDS, i) + (sent % ring) * m
    for c in range(m):
        u[c] = floats[base + c] if sent >= 0 else 0.0


@compiled
def _physics(i: int, column: int, u: np.ndarray, z: np.ndarray, floats: np.ndarray, layout: np.ndarray,
             consts: np.ndarray, steps: np.ndarray) -> None:
    """One plant step of environment ``i`` (its state in ``floats``, updated in place) with input
    ``u`` (m, and 1 for a constant term) and the per-step noise of noise step ``column``.
    ``u`` receives the jitter; ``z`` is scratch (n + columns)."""
    n, m, cols, powers = layout[_NS], layout[_NI], layout[_NC], layout[_NP]
    x0 = _fl(layout, _X, i)
    normals = _fl(layout, _NORM, i)
    jittered = layout[_NJ]
    if jittered:
        std = floats[_fl(layout, _JSTD, i) + column]
        for j in range(jittered):
            u[layout[_TABLES + j]] += std * floats[normals + layout[_OJN] + column * jittered + j]
    pushed = layout[_PUSHED] == 1
    eps = consts[m + 2 * n] * floats[normals + layout[_OPN] + column] if pushed else 0.0
    power = layout[_POWER]
    if power >= 0:
        eps = (1.0 + u[power]) * (1.0 + eps) - 1.0 if pushed else u[power]
    for k in range(n):
        z[k] = floats[x0 + k]
    for k in range(cols - n):
        z[n + k] = u[k]
    model = i if steps.shape[0] > 1 else 0  # indexed, not a view: a view costs two atomic reference counts
    for r in range(n):  # Horner's scheme in ε over the push expansion's rows, highest power first
        out = 0.0
        for p in range(powers - 1, -1, -1):
            row = 0.0
            for k in range(cols):
                row += steps[model, p * n + r, k] * z[k]
            out = row + eps * out if p < powers - 1 else row
        floats[x0 + r] = out
    impacts = layout[_NIMP]
    if impacts:
        count = math.sqrt(floats[_fl(layout, _ICNT, i) + column])
        for j in range(impacts):
            kick = count * floats[_fl(layout, _ISTD, i) + j]
            row = layout[_TABLES + jittered + j]
            floats[x0 + row] += kick * floats[normals + layout[_OIN] + column * impacts + j]


@compiled
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


@compiled
def peak_speed(z: np.ndarray, envelope: np.ndarray, model: int, speed_rows: int, speeds: np.ndarray,
               total: np.ndarray) -> float:
    """Largest lateral speed [m/s] over look-ahead table ``model`` of ``envelope`` (the norm of its
    velocity rows) from ``z`` (c,): the state and the input held
    (:func:`sail_env.physics.pointing.peak_speed`). The tables (K, R·c, S) are transposed, so that
    the sums run over all samples at once (each sample's own sum, in the same order); ``speeds`` and
    ``total`` are scratch (at least S)."""
    cols, samples = z.shape[0], envelope.shape[2]
    for r in range(speed_rows):
        for s in range(samples):
            speeds[s] = 0.0
        for k in range(cols):
            value = z[k]
            row = r * cols + k
            for s in range(samples):
                speeds[s] += envelope[model, row, s] * value
        if speed_rows == 1:
            for s in range(samples):
                total[s] = abs(speeds[s])
        elif r == 0:
            for s in range(samples):
                total[s] = speeds[s] * speeds[s]
        else:
            for s in range(samples):
                total[s] += speeds[s] * speeds[s]
    best = total[0]
    for s in range(1, samples):
        if total[s] > best:
            best = total[s]
    return math.sqrt(best) if speed_rows > 1 else best


@compiled
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


@compiled
def observe(index: np.ndarray, out: np.ndarray, floats: np.ndarray, ints: np.ndarray, layout: np.ndarray,
            consts: np.ndarray) -> None:
    """Observations (k, D) of environments ``index`` at their current step."""
    for row in range(index.shape[0]):
        i = index[row]
        _observe(i, ints[_it(layout, _STEP, i)], out, row, floats, ints, layout, consts)


@compiled
def step(action: np.ndarray, out: np.ndarray, floats: np.ndarray, ints: np.ndarray, layout: np.ndarray,
         consts: np.ndarray, steps: np.ndarray, envelope: np.ndarray, limits: np.ndarray) -> int:
    """Advance every environment one control step with ``action`` (N, m) in [-1, 1] (clipped): the
    state's fields and ``out`` (N, D) the observations. Returns how many episodes terminated (their
    scoring is the caller's); nothing changes and it returns -1 if an action is not finite, -2 if an
    episode has finished (it needs a reset)."""
    envs, n, m, cols = layout[_N], layout[_NS], layout[_NI], layout[_NC]
    for i in range(envs):
        if ints[_it(layout, _FIN, i)]:
            return -2
        for c in range(m):
            if not math.isfinite(action[i, c]):
                return -1
    u = np.empty(cols)
    z = np.empty(n + cols)
    speeds, total = np.empty(envelope.shape[2]), np.empty(envelope.shape[2])
    delayed = layout[_T] > 0
    ring, window = layout[_CR], layout[_WIN]
    ended = 0
    for i in range(envs):
        now = ints[_it(layout, _STEP, i)]
        for c in range(m):
            command = min(max(action[i, c], -1.0), 1.0) * consts[c]
            floats[_fl(layout, _LAST, i) + c] = command
            if delayed:
                floats[_fl(layout, _CMDS, i) + (now % ring) * m + c] = command
            u[c] = command
        lag = ints[_it(layout, _LAG, i)]
        if delayed:
            _applied(i, now, now, u, floats, ints, layout)
        for c in range(m):
            floats[_fl(layout, _APPLIED, i) + c] = u[c]
        if cols > n + m:
            u[m] = 1.0  # the constant term's input
        _physics(i, now + lag, u, z, floats, layout, consts, steps)
        now += 1
        ints[_it(layout, _STEP, i)] = now
        x0 = _fl(layout, _X, i)
        if delayed:
            target = _fl(layout, _HIST, i) + ((now + lag) % layout[_SR]) * n
            for k in range(n):
                floats[target + k] = floats[x0 + k]
        diverged = _diverged(i, floats, layout, limits)
        for k in range(n):  # the state and the applied input without the jitter: what the envelope holds
            z[k] = floats[x0 + k]
        for c in range(m):
            z[n + c] = floats[_fl(layout, _APPLIED, i) + c]
        speed = peak_speed(z[:cols], envelope, i if envelope.shape[0] > 1 else 0, layout[_NR], speeds, total)
        envelope_rad = speed / floats[_fl(layout, _SPEED, i)]
        floats[_fl(layout, _ENV, i)] = envelope_rad
        reward = -log_ratio_of(envelope_rad) / window
        terminated = diverged or now >= window
        floats[_fl(layout, _REWARD, i)] = DIVERGENCE_PENALTY if diverged else reward
        ints[_it(layout, _TERM, i)] = terminated
        ints[_it(layout, _DIV, i)] = diverged
        if terminated:
            ints[_it(layout, _FIN, i)] = 1
            ended += 1
        _observe(i, now, out, i, floats, ints, layout, consts)
    return ended


@compiled
def pre_control(index: np.ndarray, floats: np.ndarray, ints: np.ndarray, layout: np.ndarray, consts: np.ndarray,
                steps: np.ndarray) -> None:
    """The ``lag0`` steps before control of environments ``index`` (light delay), beam off, each
    state kept in the state ring (the first delayed observations show them)."""
    n, cols = layout[_NS], layout[_NC]
    u, z = np.empty(cols), np.empty(n + cols)
    for row in range(index.shape[0]):
        i = index[row]
        x0 = _fl(layout, _X, i)
        for s in range(ints[_it(layout, _LAG, i)]):
            u[:] = 0.0
            if cols > n + layout[_NI]:
                u[layout[_NI]] = 1.0
            _physics(i, s, u, z, floats, layout, consts, steps)
            target = _fl(layout, _HIST, i) + ((s + 1) % layout[_SR]) * n
            for k in range(n):
                floats[target + k] = floats[x0 + k]


@compiled
def in_flight(index: np.ndarray, x: np.ndarray, reached: np.ndarray, floats: np.ndarray, ints: np.ndarray,
              layout: np.ndarray, consts: np.ndarray, steps: np.ndarray) -> None:
    """After the window of environments ``index``: step each on until its last command has arrived
    (light delay). ``x`` (k, n) receives the states and ``reached`` (k,) the steps; the state buffer
    is left as the window ended."""
    n, m, cols, window = layout[_NS], layout[_NI], layout[_NC], layout[_WIN]
    u, z = np.empty(cols), np.empty(n + cols)
    last = window - 1
    for row in range(index.shape[0]):
        i = index[row]
        x0 = _fl(layout, _X, i)
        saved = floats[x0:x0 + n].copy()
        now = ints[_it(layout, _STEP, i)]
        while now - ints[_it(layout, _DELAY, i) + now] < last:
            _applied(i, now, last, u, floats, ints, layout)
            if cols > n + m:
                u[m] = 1.0
            _physics(i, now + ints[_it(layout, _LAG, i)], u, z, floats, layout, consts, steps)
            now += 1
        x[row] = floats[x0:x0 + n]
        reached[row] = now
        floats[x0:x0 + n] = saved


@compiled
def peak_speeds(index: np.ndarray, x: np.ndarray, u: np.ndarray, cols: int, speed_rows: int,
                envelope: np.ndarray, out: np.ndarray) -> None:
    """:func:`peak_speed` of environments ``index`` at states ``x`` (k, n) with inputs ``u`` (k, c - n)."""
    n = x.shape[1]
    speeds, total, z = np.empty(envelope.shape[2]), np.empty(envelope.shape[2]), np.empty(cols)
    for row in range(index.shape[0]):
        z[:n] = x[row]
        z[n:] = u[row]
        out[row] = peak_speed(z, envelope, index[row] if envelope.shape[0] > 1 else 0, speed_rows, speeds, total)
