"""The classical agents as pure JAX policies, designed by the same code as their NumPy agents
(``agents.lqr``, ``agents.lqg``, ``agents.adaptive``). What the JAX backend's samplers are compared
with the Numba backend's through (``tests/jax/test_samplers.py``); ``tests/jax/test_lqg_banks.py``
checks the LQG and the banks action for action against their NumPy agents.

A policy acts on one episode (``vmap`` batches it) and may remember: :class:`Policy` holds
``start()``, the memory of an episode about to begin, and ``act(memory, observation) -> (memory,
action)``. The LQG's memory is its estimate, the step it shows, and the commands it has sent. The
adaptive banks (``agents.adaptive``) run that LQG's step for every member side by side (``vmap`` over
the members' designs and delay tables); the members share one record of the commands sent, since the
NumPy bank replaces each member's last command with the chosen one (``replace_last_command``).

| policy | NumPy agent | memory |
|---|---|---|
| ``passive`` | :class:`agents.passive.PassiveAgent` | none |
| ``lqr`` | :class:`agents.lqr.LQRAgent` | none |
| ``lqg`` | :class:`agents.lqg.LQGAgent` (Kalman filter, delay predictor, LQR) | estimate, its step, the commands sent |
| ``lqg-mm`` | :class:`agents.adaptive.MultipleModelLQGAgent` (LQGs on a grid of models) | per member: estimate, its step, score; the commands sent |
| ``lqg-mm-offset`` | :class:`agents.adaptive.OffsetFreeMultipleModelLQGAgent` (offset-free members) | as ``lqg-mm``, the offsets estimated |
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from agents.adaptive import MultipleModelLQGAgent, OffsetFreeMultipleModelLQGAgent
from agents.lqg import LQGAgent, LQGDesign
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


class _Loops(NamedTuple):
    """LQG loops' arrays, each with a leading member axis: their :class:`~agents.lqg.LQGDesign` and the
    one-way delay [steps] each assumes at every control step its predictions reach (its agent's
    ``delay``: the nominal rule for :class:`~agents.lqg.LQGAgent`, its model's for a bank's member)."""

    phi: jax.Array
    gamma: jax.Array
    drift: jax.Array
    gain: jax.Array
    kalman_gain: jax.Array
    delay: jax.Array


def _members(spec: EpisodeSpec, agents: Sequence[LQGAgent]
             ) -> tuple[Callable[[], Memory], Callable[[Memory, jax.Array], tuple[Memory, jax.Array, jax.Array]]]:
    """The LQG loops of ``agents`` (their designs and delay rules) side by side on one episode's
    observations, predicting through one record of the commands sent: ``start()``, the memory at the
    first observation, and ``run(memory, observation) -> (memory, commands (M, m), innovations (M, n))``,
    each member's :meth:`~agents.lqg.LQGAgent.command` and :attr:`~agents.lqg.LQGAgent.innovation`.
    The memory returned holds the new estimates; which command was sent is :func:`_send`'s."""
    design = LQGDesign.stack([agent.design for agent in agents])
    window, inputs, n = spec.n_steps, spec.plant.n_inputs, spec.plant.n_states
    # Steps a prediction can cover: to the arrival of the newest command, from an estimate at most a
    # round trip old (the delay rule's largest change per step is one, so its largest in the window
    # is at the window's end).
    reach = 2 * max(int(agent.delay(np.array([window]))[0]) for agent in agents) + 3
    steps = np.arange(window + reach + 1)
    loops = _Loops(*(jnp.asarray(getattr(design, f)) for f in _Loops._fields[:-1]),
                   jnp.asarray(np.stack([agent.delay(steps) for agent in agents]), jnp.int32))
    scale = jnp.asarray(spec.action_scale)

    def applied(loop: _Loops, sent: jax.Array, step: jax.Array, newest: jax.Array) -> jax.Array:
        index = arrived_command(step, loop.delay[step], newest)
        return jnp.where(index >= 0, sent[jnp.maximum(index, 0)], 0.0)

    def advance(loop: _Loops, sent: jax.Array, newest: jax.Array, state: jax.Array, step: jax.Array,
                until: jax.Array) -> tuple[jax.Array, jax.Array]:
        def one(_: int, carry: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
            state, step = carry
            moving = step < until
            moved = loop.phi @ state + loop.gamma @ applied(loop, sent, step, newest) + loop.drift
            return jnp.where(moving, moved, state), jnp.where(moving, step + 1, step)

        return jax.lax.fori_loop(0, reach, one, (state, step))

    def member(loop: _Loops, sent: jax.Array, now: jax.Array, measured: jax.Array, estimate: jax.Array,
               estimate_step: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array]:
        """One loop's :meth:`~agents.lqg.LQGAgent.command`: its new estimate and the estimate's step,
        its clipped command and its innovation."""
        shown = now - loop.delay[now]
        fresh = now == 0  # the first observation of an episode starts the filter
        # The filter's state: the measured one, then any estimated offsets (zero at the start).
        estimate = jnp.where(fresh, jnp.zeros_like(estimate).at[:n].set(measured), estimate)
        estimate_step = jnp.where(fresh, shown, estimate_step)
        estimate, estimate_step = advance(loop, sent, now - 1, estimate, estimate_step, shown)
        innovation = measured - estimate[:n]
        estimate = estimate + loop.kalman_gain @ innovation
        prediction, _ = advance(loop, sent, now - 1, estimate, estimate_step, now + loop.delay[now])
        return estimate, estimate_step, jnp.clip(-(loop.gain @ prediction), -scale, scale), innovation

    bank = jax.vmap(member, in_axes=(0, None, None, None, 0, 0))

    def start() -> Memory:
        return {"now": jnp.zeros((), jnp.int32), "sent": jnp.zeros((window + 1, inputs)),
                "estimate": jnp.zeros(loops.drift.shape), "estimate_step": jnp.zeros(len(agents), jnp.int32)}

    def run(memory: Memory, observation: jax.Array) -> tuple[Memory, jax.Array, jax.Array]:
        estimate, estimate_step, commands, innovations = bank(
            loops, memory["sent"], memory["now"], _measured(spec, observation), memory["estimate"],
            memory["estimate_step"])
        return {**memory, "estimate": estimate, "estimate_step": estimate_step}, commands, innovations

    return start, run


def _send(spec: EpisodeSpec, memory: Memory, command: jax.Array) -> tuple[Memory, jax.Array]:
    """The memory once ``command`` [SI] is sent (the record every member predicts through), and its action."""
    now = memory["now"]
    return {**memory, "now": now + 1, "sent": memory["sent"].at[now].set(command)}, _to_action(spec, command)


def lqg_policy(spec: EpisodeSpec) -> Policy:
    """:class:`agents.lqg.LQGAgent` on one episode: its design (the same code), its filter, its
    predictor through the commands in flight by the nominal delay rule, and its clipped LQR command."""
    start, run = _members(spec, [LQGAgent(spec)])

    def act(memory: Memory, observation: jax.Array) -> tuple[Memory, jax.Array]:
        memory, commands, _ = run(memory, observation)
        return _send(spec, memory, commands[0])

    return Policy(start, act)


def _bank_policy(agent: MultipleModelLQGAgent) -> Policy:
    """A bank of :mod:`agents.adaptive` on one episode: its members' loops (the same designs and delay
    rules), each scored by its exponentially forgotten squared innovations in state scales (zero before
    the first, so that the first score is the first cost), and the command of the lowest score sent."""
    spec, forgetting = agent.spec, agent.forgetting
    members_start, run = _members(spec, agent.bank)
    state_scale = jnp.asarray(spec.state_scale)

    def start() -> Memory:
        return {**members_start(), "score": jnp.zeros(len(agent.bank))}

    def act(memory: Memory, observation: jax.Array) -> tuple[Memory, jax.Array]:
        memory, commands, innovations = run(memory, observation)
        score = forgetting * memory["score"] + jnp.sum((innovations / state_scale) ** 2, axis=-1)
        return _send(spec, {**memory, "score": score}, commands[jnp.argmin(score)])

    return Policy(start, act)


def lqg_mm_policy(spec: EpisodeSpec) -> Policy:
    """:class:`agents.adaptive.MultipleModelLQGAgent` on one episode."""
    return _bank_policy(MultipleModelLQGAgent(spec))


def lqg_mm_offset_policy(spec: EpisodeSpec) -> Policy:
    """:class:`agents.adaptive.OffsetFreeMultipleModelLQGAgent` on one episode (each member's estimate
    holds the beam offsets its design adds; its gain subtracts them)."""
    return _bank_policy(OffsetFreeMultipleModelLQGAgent(spec))


POLICIES: dict[str, Callable[[EpisodeSpec], Policy]] = {"passive": passive_policy, "lqr": lqr_policy,
                                                         "lqg": lqg_policy, "lqg-mm": lqg_mm_policy,
                                                         "lqg-mm-offset": lqg_mm_offset_policy}
