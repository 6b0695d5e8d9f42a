"""The control window's linear model against the nonlinear rigid body (research/window_vs_nonlinear.py):
in a Gaussian beam it holds at the task's own starts; in the flat-top of the aperture's size it does not
(the spot's edge on the rim kinks the force at zero offset; docs/physics.md §14).

Measured by the script over seeds 0..23 (RK4 at 0.5 ms): the flat-top's error is 31 % of the amplitude
(median; 63 % at most), the Gaussian's 0.70 % at waist 0.8 a (LightSail3DRealistic-v1; 2.6 % at most) and
0.70 % at waist a (3.1 % at most). The Gaussian's has two parts:
~0.4 % at any amplitude (0.37 % at waist a), from the window holding the Doppler power factor at its middle (the factor falls
by 6e-4 over the window and the phase drifts over its ~20 periods), and an amplitude-dependent part,
the Gaussian's anharmonicity (the lateral stiffness softens by 1e-4 at 2 cm) accumulated over those
periods, 1–3 % at the task's starts of several m/s."""

from __future__ import annotations

import numpy as np
import pytest

from research.window_vs_nonlinear import FLAT_TOP_ID, GAUSSIAN_ID, task_kwargs, window_errors, window_starts

#: The Gaussian task's seed whose window start is compared (its error is among the larger: 1.6 % at waist
#: 0.8 a, 2.1 % at a).
SEED = 0
#: RK4's step [s] here: its own phase error is ~8e-4 of the amplitude over the window at 1.25 ms.
RK4_STEP_S = 1.25e-3
#: The start scaled down to where the anharmonicity is negligible: the linear model's own accuracy.
SMALL = 0.1


@pytest.fixture(scope="module")
def gaussian_task() -> tuple[dict, np.ndarray]:
    """The Gaussian task's keyword arguments and its window start (1, 8)."""
    kwargs = task_kwargs(GAUSSIAN_ID)
    return kwargs, window_starts(kwargs, SEED + 1)[SEED:]


def test_gaussian_window_is_linear(gaussian_task):
    kwargs, start = gaussian_task
    errors, amplitudes = window_errors(kwargs, starts=np.concatenate([start, SMALL * start]), rk4_step_s=RK4_STEP_S)
    assert amplitudes[0] > 1.0  # the task's start oscillates at m/s: a real test of the model
    assert errors[1] <= 0.01, errors  # small amplitude: within 1 % (~0.4 %: the held Doppler factor)
    assert errors[0] <= 0.03, errors  # the task's amplitude: the Gaussian's anharmonicity adds 1–2 %


def test_flat_top_window_is_not(gaussian_task):
    _, start = gaussian_task
    # The same start in the flat-top task (RK4's error is irrelevant at this size: 2.5 ms).
    errors, _ = window_errors(task_kwargs(FLAT_TOP_ID), starts=start, rk4_step_s=2.5e-3)
    assert errors[0] > 0.05, errors
