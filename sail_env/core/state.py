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
import math

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

    def __getstate__(self) -> dict[str, object]:
        """What a copy or a pickle keeps: the buffers and each field's shape, not the fields (a copy of
        a view is an array of its own: the kernels would write the copied buffers, the fields not)."""
        views = (*FLOAT_FIELDS, *INT_FIELDS)
        state = {name: value for name, value in self.__dict__.items() if name not in views}
        state["shapes"] = {name: self.__dict__[name].shape[1:] for name in views}
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        """The fields again as views into the copied buffers (:meth:`__getstate__`)."""
        state = dict(state)
        shapes = state.pop("shapes")
        self.__dict__.update(state)
        self.__dict__.update(field_views(self.floats, self.ints, self.layout, shapes))


#: The fields of :class:`EpisodeState` that view the float buffer, in their order in a record,
#: with the :class:`Slot` that holds each one's offset; then those of the integer buffer.
FLOAT_FIELDS: dict[str, Slot] = {
    "x": Slot.X, "last_command": Slot.LAST_COMMAND, "applied": Slot.APPLIED, "cutoff_s": Slot.CUTOFF,
    "speed_at_cutoff": Slot.SPEED_AT_CUTOFF, "reward": Slot.REWARD, "envelope": Slot.ENVELOPE,
    "commands": Slot.COMMANDS, "states": Slot.STATE_HISTORY, "normals": Slot.NORMAL_BLOCK,
    "jitter_std": Slot.JITTER_STD, "impact_counts": Slot.IMPACT_COUNTS, "impact_std": Slot.IMPACT_STD}
INT_FIELDS: dict[str, Slot] = {"step": Slot.STEP, "finished": Slot.FINISHED, "terminated": Slot.TERMINATED,
                               "diverged": Slot.DIVERGED, "lag0": Slot.LAG0, "delay": Slot.DELAY}
_BUFFERS = ((FLOAT_FIELDS, np.float64, Slot.FLOAT_RECORD), (INT_FIELDS, np.int64, Slot.INT_RECORD))


def allocate(envs: int, layout: np.ndarray,
             shapes: dict[str, tuple[int, ...]]) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Both flat buffers (one record per environment, zeros) and a view (envs, *shape) of each field,
    by name (``shapes`` gives every field's); ``layout`` receives the fields' offsets within a record
    and the records' lengths."""
    buffers = []
    for fields, dtype, record in _BUFFERS:
        offset = 0
        for name, slot in fields.items():
            layout[slot] = offset
            offset += math.prod(shapes[name])
        layout[record] = offset
        buffers.append(np.zeros(envs * offset, dtype=dtype))
    return buffers[0], buffers[1], field_views(buffers[0], buffers[1], layout, shapes)


def field_views(floats: np.ndarray, ints: np.ndarray, layout: np.ndarray,
                shapes: dict[str, tuple[int, ...]]) -> dict[str, np.ndarray]:
    """Each field, by name, as a view (envs, *shape) into its buffer at the offsets of ``layout``."""
    views = {}
    for (fields, _, record), buffer in zip(_BUFFERS, (floats, ints)):
        table = buffer.reshape(int(layout[Slot.ENVS]), int(layout[record]))
        for name, slot in fields.items():
            start = int(layout[slot])
            view = table[:, start:start + math.prod(shapes[name])].reshape((table.shape[0], *shapes[name]))
            assert not view.size or np.shares_memory(view, buffer), name  # a view, not a copy
            views[name] = view
    return views
