"""The score's expectation on the Numba core (``expected_paths``, docs/physics.md §14 "The score's
expectation"): further coasts from the window's end through the same pieces' propagators, drawn from a
stream of their own, so that an episode's numbers do not change and ``info["expected_success"]`` estimates
the probability of success given the window's end."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401  (registers the ids)
from agents.evaluation import BASELINES, run_batch

NOISY = "LightSailUncertain-v2"


def test_the_episodes_numbers_are_the_same_with_paths_or_without():
    """Every reward, start and score of LQG's episodes to the bit, whether the paths are drawn or not."""
    agent = BASELINES["lqg"](gym.make(NOISY).unwrapped.episode_spec)
    without = run_batch(NOISY, agent, 3, 100_001, rewards=True)
    with_paths = run_batch(NOISY, agent, 3, 100_001, {"expected_paths": 8}, rewards=True)
    assert not any(e["diverged"] for e in without)  # each coasted to cut-off
    for plain, more in zip(without, with_paths):
        assert 0.0 <= more.pop("expected_success") <= 1.0
        assert plain == more


def test_each_path_is_the_coast_the_same_normals_would_give():
    """A path drawn with the normals ξ ends where the episode's own coast with ξ ends (the same
    propagators, another product order: to round-off), and leaves the beam where it does."""
    plant = gym.make(NOISY).unwrapped.episode_spec.plant
    k, paths = 3, 4
    p = plant.params(np.ones((k, plant.n_factors)) * np.array([[1.0], [0.95], [1.05]]))
    rng = np.random.default_rng(0)
    x = plant.start_limits() * rng.uniform(-0.02, 0.02, (k, plant.n_states))
    u = rng.uniform(-1e-4, 1e-4, (k, plant.n_inputs))
    duration, start = np.array([589.0, 300.0, 450.0]), np.full(k, 10.0)
    pieces = int(plant.coast_pieces(p, duration).max())
    normals = rng.standard_normal((k, paths, pieces, plant.n_states))
    _, _, path_x, path_lost = plant.coast_with_paths(p, x, u, duration, normals[:, 0], normals, start)
    for j in range(paths):
        alone, lost = plant.coast(p, x, u, duration, normals[:, j], start)
        np.testing.assert_allclose(path_x[:, j], alone, rtol=1e-8, atol=1e-15)
        np.testing.assert_array_equal(path_lost[:, j], lost)
    assert np.ptp(path_x[:, :, 2], axis=1).min() > 0  # the paths differ: their own normals act


def test_the_expected_success_agrees_with_the_sampled_one():
    """Over 100 of LQG's episodes (~60 % success) the mean expected success is the sampled success's
    within 3 standard errors of their paired difference, and each is a share of the 16 paths."""
    agent = BASELINES["lqg"](gym.make(NOISY).unwrapped.episode_spec)
    episodes = run_batch(NOISY, agent, 100, 100_000, {"expected_paths": 16})
    sampled = np.array([e["success"] for e in episodes], float)
    expected = np.array([e["expected_success"] for e in episodes])
    assert np.all(expected * 16 % 1 == 0)
    difference = sampled - expected
    assert abs(difference.mean()) < 3 * difference.std(ddof=1) / np.sqrt(len(difference))
    assert 0.3 < expected.mean() < 0.9


def test_a_fixed_coast_expects_what_it_samples():
    """LightSail-v0 coasts without noise: every path is the episode's own coast."""
    env = gym.make("LightSail-v0", expected_paths=4)
    for seed in range(3):
        env.reset(seed=seed)
        done = False
        while not done:
            _, _, done, _, info = env.step(env.action_space.sample() * 0)
        assert info["expected_success"] == float(info["is_success"])


def test_a_copy_of_the_env_plays_on_to_the_same_expectation():
    env = gym.make(NOISY, expected_paths=8)
    env.reset(seed=7)
    zero = np.zeros(env.action_space.shape, np.float32)
    for _ in range(50):
        env.step(zero)
    twin = copy.deepcopy(env)
    outcomes = []
    for one in (env, twin):
        done = False
        while not done:
            _, reward, done, _, info = one.step(zero)
        outcomes.append((reward, info["expected_success"]))
    assert outcomes[0] == outcomes[1]


@pytest.mark.parametrize("bad", [-1, 1025, 2.0, True, "8"])
def test_a_bad_count_is_refused_naming_expected_paths(bad):
    with pytest.raises(ValueError, match=r"^expected_paths must be an int in \[0, 1024\]"):
        gym.make(NOISY, expected_paths=bad)
