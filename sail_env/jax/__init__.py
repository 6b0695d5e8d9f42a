"""The JAX backend: the tasks as pure functions for ``jit``, ``vmap`` and ``lax.scan``
(gymnax's API), beside the Numba core that serves the Gym envs.

>>> import jax
>>> import sail_env.jax
>>> env, params = sail_env.jax.make("LightSail-v0")
>>> obs, state = env.reset(jax.random.key(0), params)
>>> obs, state, reward, terminated, truncated, info = env.step(jax.random.key(1), state, jax.numpy.zeros(2), params)

Importing this module turns on JAX's float64 (``jax_enable_x64``): the physics is float64, as the
Numba core's. ``import sail_env`` never imports JAX; ``pip install -e ".[jax]"`` installs it (CPU).
"""

from __future__ import annotations

import re
import warnings
from typing import Any

import jax

jax.config.update("jax_enable_x64", True)

from sail_env.envs.planar import planar_spec  # noqa: E402  (after float64 is on)
from sail_env.envs.rigid3d import rigid3d_spec  # noqa: E402
from sail_env.jax.env import EnvParams, EnvState, EpisodeStart, SailEnv, StepNoise  # noqa: E402
from sail_env.tasks import JAX_TASKS, PLANAR_TASKS, RIGID3D_TASKS  # noqa: E402

__all__ = ["EnvParams", "EnvState", "EpisodeStart", "SailEnv", "StepNoise", "make"]


def make(env_id: str, dtype: Any = jax.numpy.float64, draws: int | None = None, coast: str = "default",
         expected_paths: int = 0, terminal_reward: str = "sampled", **keywords: Any) -> tuple[SailEnv, EnvParams]:
    """The JAX env of a task id and its default params; ``keywords`` as ``gym.make``'s (a bad one
    is the same ``ValueError``). The tasks of :data:`~sail_env.tasks.JAX_TASKS`; another id's keywords are
    refused by name where the backend does not carry them yet. ``dtype``
    float32 runs the episode in single precision (faster on accelerators; the Numba core's numbers
    only to its rounding: docs/performance.md). ``draws``: the size of the bank of parameter draws a
    task with spread plays (:mod:`sail_env.jax.env`; default :data:`~sail_env.jax.env.DRAWS`, with the fast
    coast :data:`~sail_env.jax.fast_coast.FAST_DRAWS`).

    ============================  =================================================================================
    ``coast="fast"``              the realistic 3D and uncertain tasks: each draw's coast pieces built here, an
                                  episode's coast a few small products (:mod:`sail_env.jax.fast_coast`); the same
                                  episodes in law as the default coast's, not draw for draw
    ``expected_paths=K``          at each episode's end ``K`` further coasts from the window's end:
                                  ``info["expected_success"]``, the probability of success given the window,
                                  estimated without bias (their success rate)
    ``terminal_reward="expected"``  the terminal reward is its mean over those paths (the same expected return
                                  for every policy, less variance; training only: the task's score is sampled)
    ============================  ================================================================================="""
    if jax.numpy.dtype(dtype) not in (jax.numpy.float64, jax.numpy.float32):
        raise ValueError(f"dtype must be float64 or float32, got {dtype!r}")
    if draws is not None and (isinstance(draws, bool) or not isinstance(draws, (int, jax.numpy.integer))):
        raise ValueError(f"draws must be an int >= 1 (or None: the default bank), got {draws!r}")
    warn_if_out_of_date(env_id)
    if env_id in PLANAR_TASKS:
        spec = planar_spec(**{**PLANAR_TASKS[env_id], **keywords})
    elif env_id in RIGID3D_TASKS:
        spec = rigid3d_spec(**{**RIGID3D_TASKS[env_id], **keywords})
    else:
        raise ValueError(f"the JAX backend has no task {env_id!r}; it has {list(JAX_TASKS)}")
    env = SailEnv(spec, env_id, jax.numpy.dtype(dtype), draws, coast, expected_paths, terminal_reward)
    return env, env.default_params


def warn_if_out_of_date(env_id: str) -> None:
    """One warning, as ``gym.make``'s, where a later version of ``env_id``'s task is registered."""
    match = re.fullmatch(r"(.+)-v(\d+)", env_id)
    if match is None:
        return
    name, version = match[1], int(match[2])
    later = [int(other[len(name) + 2:]) for other in {**PLANAR_TASKS, **RIGID3D_TASKS}
             if re.fullmatch(rf"{re.escape(name)}-v\d+", other) and int(other[len(name) + 2:]) > version]
    if later:
        warnings.warn(f"{env_id} is out of date: its latest version is {name}-v{max(later)} (the env docstring's "
                      f"Version History says what changed)", stacklevel=3)
