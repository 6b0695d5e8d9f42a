"""The arguments of ``reset``, parsed the same way by the single and the vector envs: the seeds and
``options`` (only ``"initial_state"``). Each bad argument is one ``ValueError`` naming it."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sail_env.core.spec import EpisodeSpec
from sail_env.physics.checks import real_number

#: The keys ``reset(options=...)`` understands.
OPTION_KEYS = ("initial_state",)


def _is_int(value: object) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def reset_seeds(seed: object, count: int) -> list[int | None]:
    """The seed of each of ``count`` environments: ``None`` (fresh entropy), an int (environment ``i``
    gets ``seed + i``) or ``count`` ints or ``None``; a float, a bool or a string is refused."""
    if seed is None:
        return [None] * count
    if _is_int(seed):
        if seed < 0:
            raise ValueError(f"seed must be >= 0, got {seed}")
        return [int(seed) + i for i in range(count)]
    if isinstance(seed, (Sequence, np.ndarray)) and not isinstance(seed, str) and len(seed) == count and all(
            s is None or (_is_int(s) and s >= 0) for s in seed):
        return [None if s is None else int(s) for s in seed]
    raise ValueError(f"seed must be None, an int >= 0 or a sequence of {count} such ints or None, got {seed!r}")


def reset_states(options: object, spec: EpisodeSpec, count: int, arrays: bool) -> np.ndarray | None:
    """The launch states (count, n) ``options`` sets, checked against the spec's start limits, or
    ``None`` to draw them: ``options`` is ``None`` or a mapping with keys among :data:`OPTION_KEYS`;
    ``"initial_state"`` a dict by state name (every environment starts there) or, if ``arrays``, a
    finite real array (count, n), one row per environment."""
    if options is None:
        return None
    if not isinstance(options, Mapping):
        raise ValueError(f"options must be None or a dict with keys among {OPTION_KEYS}, got {options!r}")
    unknown = [key for key in options if key not in OPTION_KEYS]
    if unknown:
        raise ValueError(f"options keys must be among {OPTION_KEYS}, got {', '.join(map(repr, unknown))}")
    given, n = options.get("initial_state"), spec.plant.n_states
    if given is None:
        return None
    if isinstance(given, Mapping) or not arrays:
        states = np.tile(initial_state(given, spec), (count, 1))
    else:
        states = np.asarray(given)
        if states.shape != (count, n) or states.dtype.kind not in "fiu" or not np.all(np.isfinite(states)):
            raise ValueError(f"initial_state must be a dict or a finite real array of shape ({count}, {n}), "
                             f"got {states.dtype} {states.shape}")
        states = states.astype(np.float64)
    spec.check_start(states, "initial_state")
    return states


def initial_state(given: Any, spec: EpisodeSpec) -> np.ndarray:
    """The launch state from ``options["initial_state"]``: a dict of real numbers by state name
    (missing keys are zero).

    Keys are the plant's state names, and any of its ``fixed_state`` (quantities the task
    fixes, such as the 3D sail's spin), which must then have the task's value.
    """
    names, fixed = spec.plant.state_names, spec.plant.fixed_state
    valid = (*names, *fixed)
    if not isinstance(given, Mapping):
        raise ValueError(f"initial_state must be a dict with keys among {valid}, got {given!r}")
    unknown = [key for key in given if not (isinstance(key, str) and key in valid)]
    if unknown:
        raise ValueError(f"initial_state keys must be among {valid}, got {', '.join(map(repr, unknown))}")
    for key, value in fixed.items():
        if key in given and real_number(given[key], f"initial_state[{key!r}]") != value:
            raise ValueError(f"initial_state[{key!r}] is fixed by the task at {value}, got {given[key]}")
    state = np.array([real_number(given.get(name, 0.0), f"initial_state[{name!r}]") for name in names])
    if not np.all(np.isfinite(state)):
        raise ValueError(f"initial_state must be finite, got {dict(given)}")
    return state
