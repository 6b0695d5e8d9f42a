"""The classical agents as pure JAX policies, designed by the same code as their NumPy agents
(``agents.lqr``): ``policy(obs) -> action`` on one observation or, under ``vmap``, many. What the
JAX backend's samplers are compared with the Numba backend's through (``tests/jax``)."""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from agents.lqr import LQRAgent
from sail_env.core.spec import EpisodeSpec

Policy = Callable[[jax.Array], jax.Array]


def passive_policy(spec: EpisodeSpec) -> Policy:
    """The beam held still: action zero (:class:`agents.passive.PassiveAgent`)."""
    inputs = spec.plant.n_inputs
    return lambda observation: jnp.zeros(observation.shape[:-1] + (inputs,), jnp.float32)


def lqr_policy(spec: EpisodeSpec) -> Policy:
    """:class:`agents.lqr.LQRAgent`'s feedback: its gain (the same design), the measured state from
    the observation, the input scaled to an action and clipped."""
    gain = jnp.asarray(LQRAgent(spec).gain)
    state_scale, action_scale = jnp.asarray(spec.state_scale), jnp.asarray(spec.action_scale)
    states = spec.plant.n_states

    def policy(observation: jax.Array) -> jax.Array:
        state = observation[..., :states].astype(jnp.float64) * state_scale
        return jnp.clip(-(state @ gain.T) / action_scale, -1.0, 1.0).astype(jnp.float32)

    return policy


POLICIES: dict[str, Callable[[EpisodeSpec], Policy]] = {"passive": passive_policy, "lqr": lqr_policy}
