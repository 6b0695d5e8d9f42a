"""A copy of an env (``copy.deepcopy`` or ``pickle``, through ``gym.make``'s wrappers, and of the vector
env) plays on exactly as the original: observations, rewards, flags, info (the state, the terminal
pointing), the generator's stream and the episodes after the next reset, bit for bit.

The episode state's fields are views into two flat buffers that the compiled step writes; a copy
must rebuild them over its own buffers (``EpisodeState.__setstate__``), or its reward and state
freeze while its observations go on. Each test steps the original and its copies in turn, so a
copy that shared the original's arrays would show too."""

from __future__ import annotations

import copy
import pickle
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401  (registers the ids)
from sail_env.tasks import TASKS

COPIES: dict[str, Callable[[Any], Any]] = {"deepcopy": copy.deepcopy,
                                           "pickle": lambda env: pickle.loads(pickle.dumps(env))}
#: The step of the first episode at which the copies mid-episode are taken.
MIDDLE = 37


def _actions(step: int, shape: tuple[int, ...]) -> np.ndarray:
    """A fixed action sequence that steers (every input, both signs)."""
    return (0.6 * np.sin(0.31 * step + np.arange(np.prod(shape)))).reshape(shape).astype(np.float32)


def assert_same(actual: Any, expected: Any, where: str) -> None:
    """``actual`` is ``expected`` bit for bit (tests/envs/test_refusals.py uses it too): arrays and
    numbers in type, dtype, shape and bytes (NaN payloads included), dicts key by key, sequences item
    by item."""
    assert type(actual) is type(expected), where
    if isinstance(expected, dict):
        assert actual.keys() == expected.keys(), where
        for key in expected:
            assert_same(actual[key], expected[key], f"{where}[{key!r}]")
    elif isinstance(expected, (tuple, list)) or isinstance(expected, np.ndarray) and expected.dtype == object:
        assert len(actual) == len(expected), where
        for i, (a, e) in enumerate(zip(actual, expected)):
            assert_same(a, e, f"{where}[{i}]")
    elif isinstance(expected, (int, str)):  # bools too; Python ints beyond int64 (the generator's state)
        assert actual == expected, where
    elif expected is not None:
        a, e = np.asarray(actual), np.asarray(expected)
        assert (a.dtype, a.shape, a.tobytes()) == (e.dtype, e.shape, e.tobytes()), f"{where}: {actual} != {expected}"


class _Twins:
    """An env and the copies taken of it, called together: each copy must answer as the original."""

    def __init__(self, env: Any) -> None:
        self.env, self.copies = env, {}

    def take(self, when: str) -> None:
        for name, make_copy in COPIES.items():
            self.copies[f"{name} {when}"] = make_copy(self.env)

    def call(self, method: Callable[[Any], Any]) -> Any:
        expected = method(self.env)
        for name, other in self.copies.items():
            assert_same(method(other), expected, name)
        return expected


@pytest.mark.parametrize("env_id", sorted(TASKS))
def test_a_copy_of_the_env_plays_on_exactly(env_id):
    """Copies after reset, mid-episode and at the end play to the end and one more episode as the original."""
    twins = _Twins(gym.make(env_id))
    shape = twins.env.action_space.shape
    twins.env.reset(seed=5)
    twins.take("after reset")
    for episode in range(2):
        if episode:
            twins.call(lambda env: env.reset())
        step, done = 0, False
        while not done:
            action = _actions(step, shape)
            *_, terminated, truncated, _ = twins.call(lambda env: env.step(action))
            step, done = step + 1, terminated or truncated
            if episode == 0 and step == MIDDLE:
                twins.take("mid-episode")
        assert step > MIDDLE, "the copy mid-episode must be taken before the episode ends"
        if episode == 0:
            twins.take("at the end")
    twins.call(lambda env: env.unwrapped.np_random.bit_generator.state)
    for other in twins.copies.values():  # the copy draws from its own generator, the env's
        assert other.unwrapped.state.rngs[0] is other.unwrapped.np_random


@pytest.mark.parametrize("env_id", sorted(TASKS))
def test_a_copy_of_the_vector_env_plays_on_exactly(env_id):
    """Copies after reset and mid-episode play on as the original through every environment's end
    (the coast, the score, the autoreset's draws) and the next episodes' first steps."""
    twins = _Twins(gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point"))
    shape = twins.env.action_space.shape
    twins.env.reset(seed=5)
    twins.take("after reset")
    ended, step = np.zeros(2, dtype=bool), 0
    while not ended.all():
        action = _actions(step, shape)
        *_, terminated, _, _ = twins.call(lambda env: env.step(action))
        step, ended = step + 1, ended | terminated
        if step == MIDDLE:
            assert not ended.any(), "the copies mid-episode must be taken before an episode ends"
            twins.take("mid-episode")
    for step in range(step, step + 3):
        action = _actions(step, shape)
        twins.call(lambda env: env.step(action))
    twins.call(lambda env: [rng.bit_generator.state for rng in env.unwrapped.state.rngs])
