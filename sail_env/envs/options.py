"""The arguments of ``reset``, parsed the same way by the single and the vector envs: the seeds and
``options`` (``"initial_state"``, ``"params"``). Each bad argument is one ``ValueError`` naming it,
raised before anything changes (:func:`parse_reset`).

``options["params"]`` changes the task's keywords for this episode and the later ones (domain
randomisation, Gymnasium issues 905 and 1138): a dict of ``gym.make`` keywords, or a params
dataclass (:mod:`sail_env.envs.params`, whose fields set all of its family's own keywords), over the
env's current keywords; the env then plays exactly as one made with the merged keywords. A change
that would change the observation or the action space (``light_delay``, whose command history is
part of the observation; ``power_control`` on or off, an action; the timing and the sail with light
delay, which set that history's length) is refused: the env's spaces are fixed for its life.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from sail_env.core.spec import EpisodeSpec
from sail_env.physics.checks import real_number

#: The keys ``reset(options=...)`` understands.
OPTION_KEYS = ("initial_state", "params")
#: What builds a task's spec of its ``gym.make`` keywords (``planar_spec``, ``rigid3d_spec``).
SpecMaker = Callable[..., EpisodeSpec]


@dataclasses.dataclass(frozen=True)
class Reset:
    """A checked ``reset``'s arguments.

    Attributes:
        seeds: Each environment's seed (:func:`reset_seeds`).
        keywords: The task's keywords from now on (``options["params"]`` over the env's), or None: unchanged.
        spec: The spec the episodes play: the new keywords', or the env's.
        states: The launch states (count, n) ``options["initial_state"]`` sets, or None to draw them.
    """

    seeds: list[int | None]
    keywords: dict[str, Any] | None
    spec: EpisodeSpec
    states: np.ndarray | None


def parse_reset(seed: object, options: object, count: int, arrays: bool, spec: EpisodeSpec,
                keywords: Mapping[str, Any] | None, make_spec: SpecMaker | None) -> Reset:
    """Every argument of a ``reset`` of ``count`` environments checked, before anything changes: the
    seeds, the new task of ``options["params"]`` (its keywords over ``keywords``, built by ``make_spec``;
    None: an env made of a bare spec, which has none to change) and the launch states on that task."""
    seeds = reset_seeds(seed, count)
    options = reset_options(options)
    new = None
    if "params" in options:
        new, changed = task_keywords(options["params"], keywords, make_spec)
        try:
            made = make_spec(**new)
        except TypeError as error:  # an unknown keyword
            raise ValueError(f"options['params']: {error}") from None
        spec = same_spaces(made, spec, changed)
    return Reset(seeds, new, spec, reset_states(options.get("initial_state"), spec, count, arrays))


def reset_options(options: object) -> Mapping[str, Any]:
    """``options``: None (no options) or a mapping with keys among :data:`OPTION_KEYS`."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(f"options must be None or a dict with keys among {OPTION_KEYS}, got {options!r}")
    unknown = [key for key in options if key not in OPTION_KEYS]
    if unknown:
        raise ValueError(f"options keys must be among {OPTION_KEYS}, got {', '.join(map(repr, unknown))}")
    return options


def task_keywords(params: object, keywords: Mapping[str, Any] | None,
                  make_spec: SpecMaker | None) -> tuple[dict[str, Any], list[str]]:
    """The task's keywords with ``options["params"]`` (a dict of keywords or a params dataclass) over
    ``keywords``, and the names of those it changes."""
    if make_spec is None or keywords is None:
        raise ValueError("options['params']: this env was made of a bare spec (LightSailVectorEnv.from_spec), "
                         "whose keywords it does not know; make it with gym.make or gym.make_vec to change them")
    if dataclasses.is_dataclass(params) and not isinstance(params, type):
        params = {field.name: getattr(params, field.name) for field in dataclasses.fields(params) if field.init}
    if not (isinstance(params, Mapping) and all(isinstance(name, str) for name in params)):
        raise ValueError(f"options['params'] must be a dict of the env's keywords or a params dataclass "
                         f"(sail_env.envs.params), got {params!r}")
    changed = [name for name, value in params.items() if name not in keywords or not same_value(value, keywords[name])]
    return {**keywords, **params}, changed


def same_spaces(spec: EpisodeSpec, current: EpisodeSpec, changed: Sequence[str]) -> EpisodeSpec:
    """``spec``, if its observation and action spaces are ``current``'s; else one ``ValueError`` naming
    the ``changed`` keywords and the space: a reset keeps the env's spaces."""
    names = ", ".join(changed)
    if spec.plant.n_inputs != current.plant.n_inputs:
        raise ValueError(f"options['params']: {names} would change the actions from {current.plant.n_inputs} to "
                         f"{spec.plant.n_inputs} (the beam-power input of power_control); a reset keeps the "
                         f"env's spaces: make a new env for that")
    if spec.light_delay != current.light_delay or spec.observation_size != current.observation_size:
        raise ValueError(f"options['params']: {names} would change the observation from {current.observation_size} "
                         f"to {spec.observation_size} values or their meaning (the light delay and its commands in "
                         f"flight); a reset keeps the env's spaces: make a new env for that")
    return spec


def same_value(a: object, b: object) -> bool:
    """Whether two keyword values are the same (arrays element by element)."""
    try:
        return bool(np.all(np.asarray(a == b)))
    except (TypeError, ValueError):
        return False


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


def reset_states(given: object, spec: EpisodeSpec, count: int, arrays: bool) -> np.ndarray | None:
    """The launch states (count, n) ``options["initial_state"]`` (``given``) sets, checked against the
    spec's start limits, or ``None`` to draw them: a dict by state name (every environment starts
    there) or, if ``arrays``, a finite real array (count, n), one row per environment."""
    if given is None:
        return None
    n = spec.plant.n_states
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
