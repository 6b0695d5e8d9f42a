"""The JAX tasks in Gymnasium's functional API: a ``FuncEnv`` whose single and vector envs are
Gymnasium's ``FunctionalJaxEnv`` and ``FunctionalJaxVectorEnv`` (as ``phys2d/CartPole-v1``).

``gym.make("jax/LightSail-v0")`` and ``gym.make_vec("jax/LightSail-v0", num_envs=N)`` build them
(``import sail_env`` registers the ids without importing JAX); ``metadata["jax"]`` is True and
observations are JAX arrays. The functions are :class:`~sail_env.jax.env.SailEnv`'s,
so both APIs play the same episodes. As the Numba envs, they refuse an action of another shape, one
that is not finite, and a step of an episode that has ended (the single env) with one clear error,
outside the compiled functions (which cannot raise).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from gymnasium import spaces
from gymnasium.envs.functional_jax_env import FunctionalJaxEnv, FunctionalJaxVectorEnv
from gymnasium.experimental.functional import FuncEnv
from gymnasium.utils import EzPickle
from gymnasium.vector import AutoresetMode

import sail_env.jax as backend
from sail_env.core.episode import OBSERVATION_LIMIT
from sail_env.jax.env import EnvParams, EnvState, SailEnv

#: The namespace of the JAX ids: ``jax/LightSail-v0`` is ``LightSail-v0`` on this backend.
NAMESPACE = "jax"
#: What a step's info holds before the episode's end (the scores come at its end, as the Gym env's).
RUNNING_INFO = ("envelope_rad",)


class LightSailFunctional(FuncEnv):
    """A task of the JAX backend as Gymnasium's ``FuncEnv`` (``params`` default to the task's)."""

    def __init__(self, env_id: str, **keywords: Any) -> None:
        self.env, self._params = backend.make(env_id, **keywords)
        self.observation_space = spaces.Box(-OBSERVATION_LIMIT, OBSERVATION_LIMIT, (self.env.observation_size,),
                                            np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (self.env.n_inputs,), np.float32)
        super().__init__()

    def get_default_params(self, **kwargs: Any) -> EnvParams:
        return self._params

    def _given(self, params: EnvParams | None) -> EnvParams:
        return self._params if params is None else params

    def initial(self, rng: jax.Array, params: EnvParams | None = None) -> EnvState:
        return self.env.reset_env(rng, self._given(params))[1]

    def transition(self, state: EnvState, action: jax.Array, rng: jax.Array,
                   params: EnvParams | None = None) -> EnvState:
        return self.env.step_env(rng, state, action, self._given(params))[1]

    def observation(self, state: EnvState, rng: jax.Array, params: EnvParams | None = None) -> jax.Array:
        return self.env.observe_state(state, self._given(params))

    def reward(self, state: EnvState, action: jax.Array, next_state: EnvState, rng: jax.Array,
               params: EnvParams | None = None) -> jax.Array:
        return next_state.reward

    def terminal(self, state: EnvState, rng: jax.Array, params: EnvParams | None = None) -> jax.Array:
        return state.terminated

    def state_info(self, state: EnvState, params: EnvParams | None = None) -> dict:
        return {}

    def transition_info(self, state: EnvState, action: jax.Array, next_state: EnvState,
                        params: EnvParams | None = None) -> dict:
        return SailEnv.scores(next_state)


def checked_actions(actions: Any, shape: tuple[int, ...]) -> np.ndarray:
    """``actions`` as real numbers of ``shape``, finite: ``ValueError`` otherwise (JAX would broadcast a
    wrong shape and play a NaN on)."""
    array = np.asarray(actions)
    if array.shape != shape or array.dtype.kind not in "fiu":
        raise ValueError(f"action must be real numbers of shape {shape}, got {array.dtype} of shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"action must be finite, got {array}")
    return array


class LightSailJaxEnv(FunctionalJaxEnv, EzPickle):
    """One environment of a JAX task through Gymnasium's ``Env`` API (JAX arrays out)."""

    metadata = {"render_modes": [], "jax": True}

    def __init__(self, env_id: str = "LightSail-v0", render_mode: str | None = None, **keywords: Any) -> None:
        if render_mode is not None:
            raise ValueError(f"render_mode must be None (the JAX envs do not render), got {render_mode!r}")
        EzPickle.__init__(self, env_id=env_id, render_mode=render_mode, **keywords)
        func_env = LightSailFunctional(env_id, **keywords)
        func_env.transform(jax.jit)
        FunctionalJaxEnv.__init__(self, func_env, metadata=self.metadata)
        self.state: EnvState | None = None

    def step(self, action: Any) -> tuple[jax.Array, float, bool, bool, dict]:
        if self.state is None:
            raise RuntimeError("step() called before reset()")
        if bool(self.state.terminated):
            raise RuntimeError("step() called on a finished episode; call reset() first")
        obs, reward, terminated, truncated, info = super().step(checked_actions(action, self.action_space.shape))
        if not terminated:  # the scores at the end only, as the Gym env's (before it, NaN: no determinism check holds)
            info = {key: info[key] for key in RUNNING_INFO}
        return obs, reward, terminated, truncated, info


class LightSailJaxVectorEnv(FunctionalJaxVectorEnv, EzPickle):
    """N environments of a JAX task through Gymnasium's ``VectorEnv`` API (autoreset ``NEXT_STEP``)."""

    metadata = {"render_modes": [], "jax": True, "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int, env_id: str = "LightSail-v0", render_mode: str | None = None,
                 **keywords: Any) -> None:
        if render_mode is not None:
            raise ValueError(f"render_mode must be None (the JAX envs do not render), got {render_mode!r}")
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an int >= 1, got {num_envs!r}")
        EzPickle.__init__(self, num_envs=num_envs, env_id=env_id, render_mode=render_mode, **keywords)
        func_env = LightSailFunctional(env_id, **keywords)
        FunctionalJaxVectorEnv.__init__(self, func_env, num_envs=num_envs, metadata=self.metadata)
        self.func_env.transform(jax.jit)

    def step(self, action: Any) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array, dict]:
        """Gymnasium's ``FunctionalJaxVectorEnv.step`` (autoreset ``NEXT_STEP``: an environment whose episode
        ended at the last step starts a new one now), with the state a tree of arrays, which Gymnasium's
        indexes as one array."""
        action = checked_actions(action, self.action_space.shape)
        self.steps += 1
        rng, self.rng = jax.random.split(self.rng)
        rng = jax.random.split(rng, self.num_envs)
        next_state = self.func_env.transition(self.state, action, rng)
        reward = self.func_env.reward(self.state, action, next_state, rng)
        terminated = self.func_env.terminal(next_state, rng)
        truncated = self.steps >= self.time_limit if self.time_limit > 0 else jnp.zeros_like(terminated)
        info = self.func_env.transition_info(self.state, action, next_state)
        if jnp.any(self.prev_done):
            to_reset = jnp.where(self.prev_done)[0]
            rng, self.rng = jax.random.split(self.rng)
            fresh = self.func_env.initial(jax.random.split(rng, to_reset.shape[0]))
            next_state = jax.tree.map(lambda old, new: old.at[to_reset].set(new), self.state, fresh)
            self.steps = self.steps.at[to_reset].set(0)
            terminated, truncated = terminated.at[to_reset].set(False), truncated.at[to_reset].set(False)
        self.prev_done = jnp.logical_or(terminated, truncated)
        observation = self.func_env.observation(next_state, jax.random.split(self.rng, self.num_envs))
        self.state = next_state
        return observation, reward, terminated, truncated, info
