"""Residual policies (agents/residual.py) and the per-episode reset their bases need."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.env_util import make_vec_env

import sail_env  # noqa: F401
from agents import LQGAgent
from agents import evaluation as evaluate
from agents import training as train
from agents.adaptive import MultipleModelLQGAgent
from agents.residual import ResidualAgent, ResidualVecEnv, augmented, combined, residual_of
from agents.sb3 import SB3Agent

PLANAR_DELAYED = "LightSailRealistic-v0"


def _passive_observations(env_id: str, seed: int, steps: int) -> np.ndarray:
    """Observations (steps, D) of a passive episode: the same whatever an agent commands from them."""
    env = gym.make(env_id)
    obs, _ = env.reset(seed=seed)
    rows = [obs]
    for _ in range(steps - 1):
        obs, *_ = env.step(np.zeros(env.action_space.shape, np.float32))
        rows.append(obs)
    return np.array(rows)


@pytest.mark.parametrize("env_id, make", [(PLANAR_DELAYED, LQGAgent), ("LightSailUncertain-v1", MultipleModelLQGAgent)])
def test_forgetting_one_episode_of_a_batch_restarts_it_alone(env_id, make):
    """Episode 1 of a batch restarted after k steps acts as a fresh agent on its new episode; episode 0,
    not restarted, as an agent that never saw episode 1 (filter, commands in flight, bank scores)."""
    steps, k = 24, 10
    a, b, c = (_passive_observations(env_id, seed, steps) for seed in (1, 2, 3))
    spec = gym.make(env_id).unwrapped.episode_spec
    batch, alone_a, alone_c = make(spec), make(spec), make(spec)
    together, first, restarted = [], [], []
    for t in range(steps):
        if t == k:
            batch.reset(np.array([False, True]))
        together.append(batch.act(np.stack([a[t], b[t] if t < k else c[t - k]])))
        first.append(alone_a.act(a[t]))
        if t >= k:
            restarted.append(alone_c.act(c[t - k]))
    together = np.array(together)
    assert np.abs(together[k:, 1]).max() > 0.01  # the commands compared are not all zero
    np.testing.assert_allclose(together[:, 0], np.array(first), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(together[k:, 1], np.array(restarted), rtol=1e-9, atol=1e-12)


def test_combined_action_is_the_corrected_base_within_the_box():
    base = np.array([[0.5, -0.9], [0.0, 0.2]], np.float32)
    action = combined(base, np.array([[1.0, -1.0], [3.0, 0.5]]), 0.3)
    np.testing.assert_allclose(action, [[0.8, -1.0], [0.3, 0.35]], atol=1e-7)  # corrections and sums clipped
    assert action.dtype == np.float32


@pytest.mark.parametrize("hyperparams, field", [({"residual": "lqg-oracle"}, "residual"),
                                                ({"residual": "lqg", "residual_scale": 0.0}, "residual_scale"),
                                                ({"residual": "lqg", "residual_scale": 1.5}, "residual_scale"),
                                                ({"residual_scale": 0.5}, "residual_scale")])
def test_malformed_residual_settings_name_the_field(hyperparams, field):
    with pytest.raises(ValueError, match=field):
        residual_of(hyperparams)


def _base_alone(spec, seed: int, episodes: int) -> list[float]:
    """Returns of the LQG's first ``episodes`` episodes in one env seeded once (as an SB3 VecEnv's env)."""
    env, agent, returns = gym.make(PLANAR_DELAYED), LQGAgent(spec), []
    obs, _ = env.reset(seed=seed)
    for _ in range(episodes):
        agent.reset()
        total, done = 0.0, False
        while not done:
            obs, reward, terminated, truncated, _ = env.step(agent.act(obs))
            total, done = total + reward, terminated or truncated
        returns.append(total)
        obs, _ = env.reset()
    return returns


def test_a_zero_correction_plays_the_base_controller_across_autoresets():
    """Through ResidualVecEnv a policy that corrects nothing plays the base's episodes, the second of
    each env (after SB3's autoreset) too, and sees the base's action after the observation."""
    venv = ResidualVecEnv(make_vec_env(PLANAR_DELAYED, n_envs=2, seed=5), "lqg", 0.5)
    spec = venv.get_attr("episode_spec", [0])[0]
    m = spec.plant.n_inputs
    obs = venv.reset()
    np.testing.assert_allclose(obs[:, -m:], LQGAgent(spec).act(obs[:, :-m]), rtol=1e-6)
    returns, episode = np.zeros((2, 2)), np.zeros(2, int)
    while episode.min() < 2:
        obs, rewards, dones, _ = venv.step(np.zeros((2, m), np.float32))
        for i in np.flatnonzero(episode < 2):
            returns[i, episode[i]] += rewards[i]
        episode += dones
    for i in range(2):
        np.testing.assert_allclose(returns[i], _base_alone(spec, 5 + i, 2), rtol=1e-5)


@pytest.fixture(scope="module")
def residual_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("residual")
    (folder / "hp.yml").write_text(f"{PLANAR_DELAYED}:\n  n_timesteps: 128\n  normalize: true\n  n_steps: 64\n"
                                   "  batch_size: 64\n  residual: lqg\n  residual_scale: 0.2\n")
    assert train.main(["--algo", "ppo", "--env", PLANAR_DELAYED, "--n-envs", "2", "--config", str(folder / "hp.yml"),
                       "--out", str(folder / "run"), "--eval-freq", "0", "--no-progress-bar"]) == 0
    return folder / "run" / "final_model.zip"


def test_a_residual_model_is_evaluated_beside_its_base(residual_model: Path):
    env = gym.make(PLANAR_DELAYED)
    agent = evaluate.make_agent(str(residual_model), env)
    assert isinstance(agent, ResidualAgent) and isinstance(agent.base, LQGAgent) and agent.scale == 0.2
    obs, _ = env.reset(seed=0)
    agent.reset()
    action = agent.act(obs)
    base_action = LQGAgent(env.unwrapped.episode_spec).act(obs)
    correction = agent.learned.act(augmented(obs, base_action))  # a memoryless policy: the same again
    assert np.abs(correction).max() > 0
    np.testing.assert_allclose(action, combined(base_action, correction, 0.2), atol=1e-7)
    with pytest.raises(Exception, match="shape"):  # the learner alone does not take the env's observation
        SB3Agent.load(residual_model, (env.observation_space.shape[0] - 1,))


def test_the_shipped_residual_settings_train(tmp_path: Path):
    """agents/hyperparams/ppo_residual.yml (README: PPO correcting LQG on the planar realistic task)
    runs as documented, and its run records the base and the scale."""
    shipped = Path(__file__).parents[2] / "agents/hyperparams/ppo_residual.yml"
    assert train.main(["--algo", "ppo", "--env", PLANAR_DELAYED, "--config", str(shipped), "--timesteps", "64",
                       "--n-envs", "1", "--out", str(tmp_path / "run"), "--eval-freq", "0", "--no-progress-bar"]) == 0
    hyperparams = train.read_run(tmp_path / "run")["config"]["hyperparams"]
    assert hyperparams["residual"] == "lqg" and hyperparams["residual_scale"] == 0.3
