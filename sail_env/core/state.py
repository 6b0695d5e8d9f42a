"""The episode state: every per-environment array the compiled step reads and writes, as one
explicit structure beside the static :class:`~sail_env.core.spec.EpisodeSpec` (gymnax's
``EnvState``/``EnvParams`` split).

The fields are views into two flat buffers, one of floats and one of integers, described by an
integer ``layout`` (:class:`Slot` offsets and the sizes the kernels need). Each buffer holds one
record per environment, its fields side by side, so a step touches a few neighbouring cache lines
per environment rather than one stream per field (measured: no faster than separate field arrays
at N ≤ 1024 on this machine; it keeps an environment's data together for a per-thread backend). The kernels of
:mod:`sail_env.core.kernels` take the buffers, not the fields: a call costs ~50 ns per array
argument, and a step at N = 1 is a few microseconds. A GPU backend would take the same buffers and
run one thread per environment (the kernels' outer loop); none is built here.

Envs, the vector env and the agents read the state only through the fields documented on
:class:`EpisodeState`.
"""

from __future__ import annotations

import dataclasses
import enum

import numpy as np

from sail_env.physics.linear_plant import PlantParams


class Slot(enum.IntEnum):
    """Entries of the ``layout`` array: sizes, switches, then the fields' offsets in their buffer."""

    ENVS = 0  # N
    STATES = 1  # n
    INPUTS = 2  # m
    COLUMNS = 3  # columns of the plant's step matrix: n + m (+ 1 with a constant term)
    POWERS = 4  # rows of the step matrix / n: the push expansion's powers of ε
    SPEED_ROWS = 5  # velocity rows of the envelope table (1 planar, 2 in 3D)
    NOISE_STEPS = 6  # W: steps a window's per-step noise can reach (pre-control to the last arrival)
    JITTERED = 7  # inputs the beam jitter moves (J), 0 without jitter
    IMPACTS = 8  # rows random impacts kick (I), 0 without impacts
    DELAY_LENGTH = 9  # columns of the delay table (0 without light delay)
    COMMAND_RING = 10
    STATE_RING = 11
    HISTORY = 12  # commands shown in the observation
    WINDOW = 13  # control steps in the window
    PUSHED = 14  # 1 with per-step push noise
    SENSED = 15  # 1 with sensor noise
    POWER_INPUT = 16  # the input that scales the push (3D power control), -1 without
    GROUPS = 17  # divergence groups (each at most two rows; Plant.divergence_groups)
    OBSERVATION = 18  # D
    NORMALS = 19  # standard normals per environment (the row of EpisodeState.normals)
    # Offsets of the normals' parts in a row of EpisodeState.normals.
    JITTER_NORMALS = 20
    PUSH_NORMALS = 21
    SENSOR_NORMALS = 22
    IMPACT_NORMALS = 23
    # Offsets of the float fields in the float buffer.
    X = 24
    LAST_COMMAND = 25
    APPLIED = 26
    CUTOFF = 27
    SPEED_AT_CUTOFF = 28
    REWARD = 29
    ENVELOPE = 30
    COMMANDS = 31
    STATE_HISTORY = 32
    NORMAL_BLOCK = 33
    JITTER_STD = 34
    IMPACT_COUNTS = 35
    IMPACT_STD = 36
    # Offsets of the integer fields in the integer buffer.
    STEP = 37
    FINISHED = 38
    TERMINATED = 39
    DIVERGED = 40
    LAG0 = 41
    DELAY = 42
    # The length of one environment's record in each buffer.
    FLOAT_RECORD = 43
    INT_RECORD = 44
    # Then: the jitter's inputs (J), the impacts' rows (I), the divergence groups (2 per group, -1 pads).
    TABLES = 45


@dataclasses.dataclass
class EpisodeState:
    """The state of N episodes (every array leads with N; SI units).

    Attributes:
        x: (N, n) the true state.
        step: (N,) control steps taken in the current window.
        last_command: (N, m) the command sent at the last step (held over the coast).
        applied: (N, m) the beam input that acted during the last step (the newest arrived command).
        finished: (N,) 1 once the episode has terminated (a new one starts at reset).
        terminated, diverged: (N,) 1 if the last step ended the episode / left the beam.
        reward, envelope: (N,) the last step's reward and envelope (largest ``|V⊥|/Vz`` with the
            applied input held).
        cutoff_s: (N,) the beam cut-off time of the episode.
        speed_at_cutoff: (N,) the axial speed at cut-off (divides the lateral speed in the envelope).
        lag0: (N,) one-way delay [steps] at the start of control (zero without light delay).
        delay: (N, T) the one-way delay at each step (T = 0 without light delay).
        commands: (N, C, m) ring of the sent commands (the command of step ``s`` at ``s % C``).
        states: (N, S, n) ring of true states, the state after step ``s`` at ``(s + lag0) % S`` (the
            delayed observation's source).
        normals: (N, K) the window's standard normals drawn at reset, in order: beam jitter (W, J),
            push (W), sensor (window + 1, n), impacts (W, I); W noise steps, indexed by the step
            plus ``lag0`` (pre-control steps first).
        jitter_std: (N, W) the beam jitter's standard deviation at each noise step [m].
        impact_counts, impact_std: (N, W) the impacts' Poisson count per noise step; (N, I) the
            standard deviation of one impact's kick on each impulse row.
        params: the plant's :class:`~sail_env.physics.linear_plant.PlantParams` (leading axis N, or 1 when shared).
        rngs: each environment's generator (None before its first reset).
    """

    x: np.ndarray
    step: np.ndarray
    last_command: np.ndarray
    applied: np.ndarray
    finished: np.ndarray
    terminated: np.ndarray
    diverged: np.ndarray
    reward: np.ndarray
    envelope: np.ndarray
    cutoff_s: np.ndarray
    speed_at_cutoff: np.ndarray
    lag0: np.ndarray
    delay: np.ndarray
    commands: np.ndarray
    states: np.ndarray
    normals: np.ndarray
    jitter_std: np.ndarray
    impact_counts: np.ndarray
    impact_std: np.ndarray
    params: PlantParams
    rngs: list[np.random.Generator | None]
    floats: np.ndarray  # the float buffer the float fields view (what the kernels take)
    ints: np.ndarray  # the integer buffer
    layout: np.ndarray  # Slot entries, then the tables


def allocate(envs: int, layout: np.ndarray, float_shapes: dict[Slot, tuple[int, ...]],
             int_shapes: dict[Slot, tuple[int, ...]]) -> tuple[np.ndarray, np.ndarray, dict[Slot, np.ndarray]]:
    """Both flat buffers (one record per environment) and a view (envs, *shape) of each field;
    ``layout`` receives the fields' offsets within a record and the records' lengths."""
    views: dict[Slot, np.ndarray] = {}
    buffers = []
    for shapes, dtype, record in ((float_shapes, np.float64, Slot.FLOAT_RECORD), (int_shapes, np.int64, Slot.INT_RECORD)):
        sizes = {slot: int(np.prod(shape)) for slot, shape in shapes.items()}
        layout[record] = length = sum(sizes.values())
        table = np.zeros((envs, length), dtype=dtype)
        offset = 0
        for slot, shape in shapes.items():
            layout[slot] = offset
            view = table[:, offset:offset + sizes[slot]].reshape((envs, *shape))
            assert view.base is not None and np.shares_memory(view, table) or not view.size
            views[slot] = view
            offset += sizes[slot]
        buffers.append(table.reshape(-1))
    return buffers[0], buffers[1], views
