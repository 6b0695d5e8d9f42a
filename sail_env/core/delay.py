"""The light-delay rule, used by the episode core and by delay-compensating controllers."""

from __future__ import annotations

import numpy as np

from sail_env.jit import compiled
from sail_env.physics.mission import one_way_light_delay_s

# Numba's cache follows this file alone: the line below (tests/test_numba_cache.py) changes it when
# a file whose code or constants its compiled functions take in changes, so that they compile again.
# compiled in: sail_env/jit.py sha256:9d3b73adb7f50647


def delay_steps(acceleration_m_s2: np.ndarray | float, control_start_s: float, dt: float,
                steps: np.ndarray | int) -> np.ndarray:
    """One-way light delay ``D(t)/c`` at control step ``steps``, rounded to whole steps.

    The observation at step ``s`` shows the state of step ``s − delay(s)``; the command
    sent at step ``j`` acts during every step ``s`` with ``s − delay(s) = j`` (the newest
    command that has arrived is held: :func:`arrived_command`). Ranging tells a ground station
    its distance, so a controller may use this rule. Arguments broadcast; the result is an
    integer array.
    """
    t = control_start_s + np.asarray(steps) * dt
    return np.rint(one_way_light_delay_s(np.asarray(acceleration_m_s2), t) / dt).astype(np.int64)


@compiled
def arrived_command(step: int, delay: int, newest: int) -> int:
    """The index of the command acting during ``step`` (whose one-way delay is ``delay`` steps):
    the newest that has arrived, at most ``newest`` (the last one sent); -1 before any arrives
    (the beam input is then zero). The compiled step and the LQG's predictor both ask this."""
    sent = min(step - delay, newest)
    return sent if sent >= 0 else -1


@compiled
def arrived_commands(steps: np.ndarray, delays: np.ndarray, newest: np.ndarray, out: np.ndarray) -> None:
    """:func:`arrived_command` of each environment (arrays (N,) of integers) into ``out`` (N,)."""
    for i in range(steps.shape[0]):
        out[i] = arrived_command(steps[i], delays[i], newest[i])
