"""Potential-based reward shaping (agents/shaping.py) against the env's own terms, read from its infos."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from stable_baselines3.common.env_util import make_vec_env

import sail_env  # noqa: F401
from agents import training as train
from agents.shaping import PotentialShapingVecEnv, shaping_of
from sail_env.core.reward import SUCCESS_BONUS, log_ratio

GAMMA = 0.98


def _potential(info: dict) -> float:
    """Φ = −ρ(envelope), from the envelope the env reports (not from its reward, as the wrapper does)."""
    return -float(log_ratio(np.array([info["envelope_rad"]]))[0])


def test_shaped_rewards_are_the_potential_differences_and_keep_the_discounted_return():
    """Each step pays γΦ(s′) − Φ(s) with Φ from the env's reported envelope; at the end the env's
    last reward − Φ(s); so an episode's discounted shaped return is γᴺ⁻¹ × (the pointing's reward
    with its bonus and the last step's envelope share), which the infos give independently."""
    plain = make_vec_env("LightSail-v0", n_envs=2, seed=3)
    shaped = PotentialShapingVecEnv(make_vec_env("LightSail-v0", n_envs=2, seed=3), GAMMA)
    steps = shaped.window_steps
    rng = np.random.default_rng(0)
    plain.reset(), shaped.reset()
    previous, returns, t, ended = np.zeros(2), np.zeros(2), 0, np.zeros(2, bool)
    while not ended.all():
        actions = rng.uniform(-0.3, 0.3, (2, 2)).astype(np.float32)
        _, _, dones, infos = plain.step(actions)
        _, shaped_rewards, shaped_dones, _ = shaped.step(actions)
        np.testing.assert_array_equal(dones, shaped_dones)
        for i in np.flatnonzero(~ended):
            if dones[i]:
                assert not infos[i]["diverged"]
                last = (-log_ratio(np.array([infos[i]["terminal_pointing_rad"]]))[0]
                        + SUCCESS_BONUS * infos[i]["is_success"] + _potential(infos[i]) / steps)
                np.testing.assert_allclose(shaped_rewards[i], last - previous[i], rtol=1e-5, atol=1e-5)
                returns[i] += GAMMA ** t * shaped_rewards[i]
                np.testing.assert_allclose(returns[i], GAMMA ** t * last, rtol=1e-4, atol=1e-4)
                ended[i] = True
            else:
                potential = _potential(infos[i])
                np.testing.assert_allclose(shaped_rewards[i], GAMMA * potential - previous[i], rtol=1e-5, atol=1e-5)
                returns[i] += GAMMA ** t * shaped_rewards[i]
                previous[i] = potential
        t += 1
    assert t == steps


def test_the_potential_starts_at_zero_in_the_episode_after_an_autoreset():
    """After SB3's autoreset the next step pays γΦ(s′) with no term from the ended episode."""
    shaped = PotentialShapingVecEnv(make_vec_env("LightSail-v0", n_envs=1, seed=0), GAMMA)
    plain = make_vec_env("LightSail-v0", n_envs=1, seed=0)
    shaped.reset(), plain.reset()
    zero = np.zeros((1, 2), np.float32)
    for _ in range(shaped.window_steps):
        shaped.step(zero), plain.step(zero)
    _, _, done, info = plain.step(zero)
    _, shaped_reward, _, _ = shaped.step(zero)
    assert not done[0]
    np.testing.assert_allclose(shaped_reward[0], GAMMA * _potential(info[0]), rtol=1e-5)


@pytest.mark.parametrize("value", ["dense", 1, True])
def test_an_unknown_shaping_names_the_field(value):
    with pytest.raises(ValueError, match="reward_shaping"):
        shaping_of({"reward_shaping": value})


def test_the_shipped_shaping_settings_train_and_record_their_shaping(tmp_path: Path):
    """agents/hyperparams/ppo_shaping.yml (docs/learners.md) runs as documented, with selection
    episodes (their env is wrapped alike, or SB3 cannot sync the normalisation)."""
    shipped = Path(__file__).parents[2] / "agents/hyperparams/ppo_shaping.yml"
    assert train.main(["--algo", "ppo", "--env", "LightSail3DRealistic-v1", "--config", str(shipped),
                       "--timesteps", "64", "--n-envs", "1", "--out", str(tmp_path / "run"), "--eval-freq", "64",
                       "--eval-episodes", "2", "--no-progress-bar"]) == 0
    assert train.read_run(tmp_path / "run")["config"]["hyperparams"]["reward_shaping"] == "potential"
