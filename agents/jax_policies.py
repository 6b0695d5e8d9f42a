"""The classical agents as pure JAX policies, designed by the same code as their NumPy agents
(``agents.lqr``, ``agents.lqg``). What the JAX backend's samplers are compared with the Numba
backend's through (``tests/jax/test_samplers.py``).

A policy acts on one episode (``vmap`` batches it) and may remember: :class:`Policy` holds
``start()``, the memory of an episode about to begin, and ``act(memory, observation) -> (memory,
action)``. The LQG's memory is its estimate, the step it shows, and the commands it has sent.

| policy | NumPy agent | memory |
|---|---|---|
| ``passive`` | :class:`agents.passive.PassiveAgent` | none |
| ``lqr`` | :class:`agents.lqr.LQRAgent` | none |
| ``lqg`` | :class:`agents.lqg.LQGAgent` (Kalman filter, delay predictor, LQR) | estimate, its step, the commands sent |
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from agents.lqg import LQGAgent
from agents.lqr import LQRAgent
from sail_env.core.spec import EpisodeSpec
from sail_env.jax.env import arrived_command

Memory = Any


@dataclasses.dataclass(frozen=True)
class Policy:
    """A pure policy for one episode: ``start()`` is its memory at the first observation,
    ``act(memory, observation)`` returns the new memory and the action in [-1, 1] (float32)."""

    start: Callable[[], Memory]
    act: Callable[[Memory, jax.Array], tuple[Memory, jax.Array]]


def _measured(spec: EpisodeSpec, observation: jax.Array) -> jax.Array:
    """:meth:`~sail_env.core.spec.EpisodeSpec.observation_to_state` in JAX."""
    return observation[:spec.plant.n_states].astype(jnp.float64) * jnp.asarray(spec.state_scale)


def _to_action(spec: EpisodeSpec, command: jax.Array) -> jax.Array:
    """:meth:`~sail_env.core.spec.EpisodeSpec.input_to_action` in JAX."""
    return jnp.clip(command / jnp.asarray(spec.action_scale), -1.0, 1.0).astype(jnp.float32)


def passive_policy(spec: EpisodeSpec) -> Policy:
    """The beam held still: action zero (:class:`agents.passive.PassiveAgent`)."""
    inputs = spec.plant.n_inputs
    return Policy(lambda: (), lambda memory, observation: (memory, jnp.zeros(inputs, jnp.float32)))


def lqr_policy(spec: EpisodeSpec) -> Policy:
    """:class:`agents.lqr.LQRAgent`'s feedback: its gain (the same design) on the measured state."""
    gain = jnp.asarray(LQRAgent(spec).gain)
    return Policy(lambda: (), lambda memory, observation: (memory, _to_action(spec, -(gain @ _measured(spec,
                                                                                                      observation)))))


def lqg_policy(spec: EpisodeSpec) -> Policy:
    """:class:`agents.lqg.LQGAgent` on one episode: its design (the same code), its filter, its
    predictor through the commands in flight by the nominal delay rule, and its clipped LQR command."""
    design = LQGAgent(spec).design
    phi, gamma, drift, gain, kalman = (jnp.asarray(getattr(design, f)) for f in
                                       ("phi", "gamma", "drift", "gain", "kalman_gain"))
    window, inputs = spec.n_steps, spec.plant.n_inputs
    # Steps a prediction can cover: to the arrival of the newest command, from an estimate at most
    # a round trip old (the delay rule's largest change per step is one).
    reach = 2 * spec.max_delay + 3
    delay = jnp.asarray(spec.delay_steps(np.arange(window + reach + 1)), jnp.int32)
    scale = jnp.asarray(spec.action_scale)

    def applied(sent: jax.Array, step: jax.Array, newest: jax.Array) -> jax.Array:
        index = arrived_command(step, delay[step], newest)
        return jnp.where(index >= 0, sent[jnp.maximum(index, 0)], 0.0)

    def advance(sent: jax.Array, newest: jax.Array, state: jax.Array, step: jax.Array,
                until: jax.Array) -> tuple[jax.Array, jax.Array]:
        def one(_: int, carry: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
            state, step = carry
            moving = step < until
            moved = phi @ state + gamma @ applied(sent, step, newest) + drift
            return jnp.where(moving, moved, state), jnp.where(moving, step + 1, step)

        return jax.lax.fori_loop(0, reach, one, (state, step))

    def start() -> Memory:
        return {"now": jnp.zeros((), jnp.int32), "sent": jnp.zeros((window + 1, inputs)),
                "estimate": jnp.zeros(phi.shape[0]), "estimate_step": jnp.zeros((), jnp.int32)}

    def act(memory: Memory, observation: jax.Array) -> tuple[Memory, jax.Array]:
        now, sent = memory["now"], memory["sent"]
        measured = _measured(spec, observation)
        shown = now - delay[now]
        fresh = now == 0  # the first observation of an episode starts the filter
        estimate = jnp.where(fresh, measured, memory["estimate"])
        estimate_step = jnp.where(fresh, shown, memory["estimate_step"])
        estimate, estimate_step = advance(sent, now - 1, estimate, estimate_step, shown)
        estimate = estimate + kalman @ (measured - estimate)
        prediction, _ = advance(sent, now - 1, estimate, estimate_step, now + delay[now])
        command = jnp.clip(-(gain @ prediction), -scale, scale)
        memory = {"now": now + 1, "sent": sent.at[now].set(command), "estimate": estimate,
                  "estimate_step": estimate_step}
        return memory, _to_action(spec, command)

    return Policy(start, act)


POLICIES: dict[str, Callable[[EpisodeSpec], Policy]] = {"passive": passive_policy, "lqr": lqr_policy,
                                                         "lqg": lqg_policy}
