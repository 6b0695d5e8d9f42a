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

The fields are declared once, as plain data (:data:`FIELDS`: name, dtype, shape in the layout's
sizes of :data:`SIZES`, the layout entry of the offset): :class:`Slot`, :class:`EpisodeState`, the
buffers' records and the views follow from it, and a backend of other arrays (a JAX pytree) can read it
too. A new field is one :class:`Field` (and a size in :data:`SIZES` if it needs a new one, set in
:class:`~sail_env.core.episode.EpisodeCore`).

Envs, the vector env and the agents read the state only through the fields documented on
:class:`EpisodeState`.
"""

from __future__ import annotations

import dataclasses
import enum
import math

import numpy as np

from sail_env.physics.linear_plant import PlantParams

#: The layout's first entries, by name: the sizes and switches of one task's episodes (set by
#: :class:`~sail_env.core.episode.EpisodeCore`), in :data:`FIELDS`' shapes and the kernels' loops.
SIZES: dict[str, str] = {
    "ENVS": "N",
    "STATES": "n",
    "INPUTS": "m",
    "COLUMNS": "columns of the plant's step matrix: n + m (+ 1 with a constant term)",
    "POWERS": "rows of the step matrix / n: the push expansion's powers of ε",
    "SPEED_ROWS": "velocity rows of the envelope table (1 planar, 2 in 3D)",
    "NOISE_STEPS": "W: steps a window's per-step noise can reach (pre-control to the last arrival)",
    "JITTERED": "inputs the beam jitter moves (J), 0 without jitter",
    "JITTER_STEPS": "W with beam jitter, else 0",
    "IMPACTS": "rows random impacts kick (I), 0 without impacts",
    "IMPACT_STEPS": "W with random impacts, else 0",
    "DELAY_LENGTH": "T: columns of the delay table (0 without light delay)",
    "COMMAND_RING": "C: sent commands kept",
    "STATE_RING": "S: true states kept",
    "HISTORY": "commands shown in the observation",
    "WINDOW": "control steps in the window",
    "PUSHED": "1 with per-step push noise",
    "SENSED": "1 with sensor noise",
    "POWER_INPUT": "the input that scales the push (3D power control), -1 without",
    "GROUPS": "divergence groups (each at most two rows; Plant.divergence_groups)",
    "OBSERVATION": "D",
    "NORMALS": "K: standard normals per environment (a row of EpisodeState.normals)",
    "JITTER_NORMALS": "offset of the beam jitter's normals in a row of EpisodeState.normals",
    "PUSH_NORMALS": "offset of the push noise's normals there",
    "SENSOR_NORMALS": "offset of the sensor noise's normals there",
    "IMPACT_NORMALS": "offset of the impacts' normals there",
}


@dataclasses.dataclass(frozen=True)
class Field:
    """One array of the episode state: per environment, ``shape`` (names of :data:`SIZES`) of
    ``dtype`` (``"float64"`` or ``"int64"``: which buffer holds it), at the offset in its environment's
    record that the layout entry ``offset`` holds (the kernels' name for it)."""

    name: str
    dtype: str
    shape: tuple[str, ...]
    offset: str
    doc: str


#: The episode state's arrays, each buffer's in the order of its record.
FIELDS: tuple[Field, ...] = (
    Field("x", "float64", ("STATES",), "X", "the true state"),
    Field("last_command", "float64", ("INPUTS",), "LAST_COMMAND",
          "the command sent at the last step (held over the coast)"),
    Field("applied", "float64", ("INPUTS",), "APPLIED",
          "the beam input that acted during the last step (the newest arrived command)"),
    Field("cutoff_s", "float64", (), "CUTOFF", "the beam cut-off time of the episode"),
    Field("speed_at_cutoff", "float64", (), "SPEED_AT_CUTOFF",
          "the axial speed at cut-off (divides the lateral speed in the envelope)"),
    Field("reward", "float64", (), "REWARD", "the last step's reward"),
    Field("envelope", "float64", (), "ENVELOPE",
          "the last step's envelope (largest ``|V⊥|/Vz`` with the applied input held)"),
    Field("commands", "float64", ("COMMAND_RING", "INPUTS"), "COMMANDS",
          "ring of the sent commands (the command of step ``s`` at ``s % C``)"),
    Field("states", "float64", ("STATE_RING", "STATES"), "STATE_HISTORY",
          "ring of true states, the state after step ``s`` at ``(s + lag0) % S`` (the delayed observation's source)"),
    Field("normals", "float64", ("NORMALS",), "NORMAL_BLOCK",
          "the window's standard normals drawn at reset, in order: beam jitter (W, J), push (W), sensor "
          "(window + 1, n), impacts (W, I); W noise steps, indexed by the step plus ``lag0`` (pre-control steps first)"),
    Field("jitter_std", "float64", ("JITTER_STEPS",), "JITTER_STD",
          "the beam jitter's standard deviation at each noise step [m]"),
    Field("impact_counts", "float64", ("IMPACT_STEPS",), "IMPACT_COUNTS", "the impacts' Poisson count per noise step"),
    Field("impact_std", "float64", ("IMPACTS",), "IMPACT_STD",
          "the standard deviation of one impact's kick on each impulse row"),
    Field("step", "int64", (), "STEP", "control steps taken in the current window"),
    Field("finished", "int64", (), "FINISHED", "1 once the episode has terminated (a new one starts at reset)"),
    Field("terminated", "int64", (), "TERMINATED", "1 if the last step ended the episode"),
    Field("diverged", "int64", (), "DIVERGED", "1 if the last step left the beam"),
    Field("lag0", "int64", (), "LAG0", "one-way delay [steps] at the start of control (zero without light delay)"),
    Field("delay", "int64", ("DELAY_LENGTH",), "DELAY", "the one-way delay at each step"),
)
_DTYPES = ("float64", "int64")  # the buffers, ``floats`` and ``ints``

#: Entries of the ``layout`` array: :data:`SIZES`, the fields' offsets in their record (:data:`FIELDS`),
#: each buffer's record length, then ``TABLES``: the jitter's inputs (J), the impacts' rows (I), the
#: divergence groups (2 per group, -1 pads).
Slot = enum.IntEnum("Slot", [*SIZES, *(f.offset for dtype in _DTYPES for f in FIELDS if f.dtype == dtype),
                             "FLOAT_RECORD", "INT_RECORD", "TABLES"], start=0, module=__name__)
_RECORDS = {"float64": Slot.FLOAT_RECORD, "int64": Slot.INT_RECORD}


def _state_doc() -> str:
    fields = "\n".join(f"        {f.name}: ({', '.join(('N', *f.shape))}{'' if f.shape else ','}) {f.doc}."
                       for f in FIELDS)
    return f"""The state of N episodes (every array leads with N; SI units; the sizes' names are :data:`SIZES`).

    Attributes:
{fields}
        params: the plant's :class:`~sail_env.physics.linear_plant.PlantParams` (leading axis N, or 1 when shared).
        rngs: each environment's generator (None before its first reset).
        floats, ints: the buffers the fields view (what the kernels take).
        layout: the :class:`Slot` entries, then the tables.
    """


def _getstate(self: EpisodeState) -> dict[str, object]:
    """What a copy or a pickle keeps: the buffers, not the fields (a copy of a view is an array of its
    own: the kernels would write the copied buffers, the fields not)."""
    return {name: value for name, value in self.__dict__.items() if name not in {f.name for f in FIELDS}}


def _setstate(self: EpisodeState, state: dict[str, object]) -> None:
    """The fields again as views into the copied buffers (:func:`_getstate`)."""
    self.__dict__.update(state)
    self.__dict__.update(field_views(self.floats, self.ints, self.layout))


#: The episode state: a view of its buffers for each of :data:`FIELDS`, and the rest.
EpisodeState = dataclasses.make_dataclass(
    "EpisodeState", [*((f.name, np.ndarray) for f in FIELDS), ("params", PlantParams),
                     ("rngs", "list[np.random.Generator | None]"), ("floats", np.ndarray), ("ints", np.ndarray),
                     ("layout", np.ndarray)],
    namespace={"__doc__": _state_doc(), "__getstate__": _getstate, "__setstate__": _setstate,
               "__module__": __name__})


def field_shape(field: Field, layout: np.ndarray) -> tuple[int, ...]:
    """The shape of ``field`` per environment in the task of ``layout``."""
    return tuple(int(layout[Slot[size]]) for size in field.shape)


def allocate(layout: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Both flat buffers (one record per environment, zeros) and a view (N, *shape) of each field, by
    name, for the sizes in ``layout``; ``layout`` receives the fields' offsets within a record and the
    records' lengths."""
    buffers = []
    for dtype in _DTYPES:
        offset = 0
        for field in (f for f in FIELDS if f.dtype == dtype):
            layout[Slot[field.offset]] = offset
            offset += math.prod(field_shape(field, layout))
        layout[_RECORDS[dtype]] = offset
        buffers.append(np.zeros(int(layout[Slot.ENVS]) * offset, dtype=dtype))
    return buffers[0], buffers[1], field_views(buffers[0], buffers[1], layout)


def field_views(floats: np.ndarray, ints: np.ndarray, layout: np.ndarray) -> dict[str, np.ndarray]:
    """Each field, by name, as a view (N, *shape) into its buffer at the offsets of ``layout``."""
    envs, views = int(layout[Slot.ENVS]), {}
    tables = {dtype: buffer.reshape(envs, int(layout[_RECORDS[dtype]]))
              for dtype, buffer in zip(_DTYPES, (floats, ints))}
    for field in FIELDS:
        start, size = int(layout[Slot[field.offset]]), field_shape(field, layout)
        view = tables[field.dtype][:, start:start + math.prod(size)].reshape((envs, *size))
        assert not view.size or np.shares_memory(view, tables[field.dtype]), field.name  # a view, not a copy
        views[field.name] = view
    return views
