"""The episode core against the numbers of v0.1.0's scalar env (recorded before the core replaced
it, in tests/data/episodes_v0_1_0.json), and the vector env against the single env."""

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401
from sail_env.physics import DEEP_DISH, SEED
from sail_env.physics.planar.model import STATE_NAMES
from sail_env.tasks import PLANAR_TASKS as TASKS

REFERENCE = json.loads((Path(__file__).parents[1] / "data" / "episodes_v0_1_0.json").read_text())
CASES = {"LightSail-v0": {}, "LightSailDeepDish-v0": {}, "LightSail-v0|flat": {"config": "flat"},
         "LightSail-v0|delay10s": {"config": SEED.replace(control_start_s=10.0), "light_delay": True},
         "LightSailDeepDish-v0|delay10s": {"config": DEEP_DISH.replace(control_start_s=10.0), "light_delay": True}}


@pytest.mark.parametrize("case", sorted(CASES))
def test_noise_free_episodes_are_those_of_v0_1_0(case):
    env = gym.make(case.split("|")[0], **CASES[case])
    for recorded in REFERENCE[case]["episodes"]:
        rng = np.random.default_rng(recorded["seed"])  # the recorded episodes' random actions
        obs, _ = env.reset(seed=recorded["seed"])
        np.testing.assert_array_equal(obs, recorded["first_obs"])
        rewards, done = [], False
        while not done:
            obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            rewards.append(reward)
            done = terminated or truncated
            if len(rewards) == 7:
                np.testing.assert_array_equal(obs, recorded["obs_7"])
        np.testing.assert_allclose(rewards[:-1], recorded["rewards"][:-1], rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(obs, recorded["last_obs"])
        # The last reward holds the score, log10 of the pointing after the coast: the exponential of
        # its ~40,000 rad of phase amplifies round-off, which differs between CPUs' BLAS kernels
        # (1e-11 of the pointing between the recording's machine and an AMD EPYC).
        assert info["terminal_pointing_rad"] == pytest.approx(recorded["pointing"], rel=1e-9)
        assert rewards[-1] == pytest.approx(recorded["rewards"][-1], abs=1e-9)
        assert info["is_success"] == recorded["success"] and info["diverged"] == recorded["diverged"]


#: The realistic task started 9.25 s out: the parameter draws end the window with one-way delays of
#: 3 and 4 steps in one batch, so the commands still in flight run out at different steps.
MIXED_DELAYS = ("LightSailRealistic-v0", {"config": DEEP_DISH.replace(control_start_s=9.25)}, None, 10)
#: Seeded with 0, environment 3's draw starts control with a 4-step delay, the others with 3.
MIXED_FIRST_DELAYS = ("LightSailRealistic-v0", {}, None, 0)
#: Strong push noise makes the spread grow as e^{0.75 t} over the coast (parametric excitation), so
#: the coast runs in pieces of e^20; cut-offs around 614 s give 23 or 24 of them in one batch.
MIXED_PIECES = ("LightSailDeepDish-v0", {"config": DEEP_DISH.replace(beam_cutoff_s=614.0), "push_noise": 0.2,
                                         "cutoff_jitter_s": 5.0}, None, 10)
#: Environment 0 starts leaving the beam, ends at its first step and plays on one step behind the
#: others: later windows end for only part of the batch, each with its own parameter draw.
OUT_OF_STEP = ("LightSailRealistic-v0", {}, np.array([[1.9, 300.0, 0.0, 0.0]] + [[0.0, 0.0, 0.0, 0.0]] * 4), 10)


@pytest.mark.parametrize("env_id, kwargs, first_states, seed", [(env_id, {}, None, 10) for env_id in sorted(TASKS)]
                         + [MIXED_DELAYS, MIXED_FIRST_DELAYS, MIXED_PIECES, OUT_OF_STEP])
def test_vector_env_plays_the_single_envs_episodes(env_id, kwargs, first_states, seed):
    """Environment i of the batch seeded with s is a single env seeded with s + i, across autoresets."""
    n, steps = 5, 450  # two whole episodes and part of a third
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, n, 2)).astype(np.float32)
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)
    options = None if first_states is None else {"initial_state": first_states}
    obs, _ = envs.reset(seed=seed, options=options)
    batch_obs, batch_rewards, batch_scores = [obs], [], []
    for k in range(steps):
        obs, reward, terminated, truncated, info = envs.step(actions[k])
        batch_obs.append(obs)
        batch_rewards.append(reward)
        if terminated.any():
            final = info["final_info"]
            batch_scores += [(i, final["terminal_pointing_rad"][i], final["is_success"][i]) for i in np.flatnonzero(terminated)]
            np.testing.assert_array_equal(info["_final_obs"], terminated)
            assert all(np.asarray(value).dtype.kind in "fb" for value in final.values())  # numbers, as SyncVectorEnv's
    batch_obs, batch_rewards = np.array(batch_obs), np.array(batch_rewards)
    single_scores = []
    for i in range(n):
        env = gym.make(env_id, **kwargs)
        options = None if first_states is None else {"initial_state": dict(zip(STATE_NAMES, first_states[i]))}
        obs, _ = env.reset(seed=seed + i, options=options)
        observations, rewards = [obs], []
        for k in range(steps):
            obs, reward, terminated, truncated, info = env.step(actions[k, i])
            rewards.append(reward)
            if terminated:
                single_scores.append((i, info["terminal_pointing_rad"], info["is_success"]))
                obs, _ = env.reset()
            observations.append(obs)
        np.testing.assert_allclose(np.array(observations), batch_obs[:, i], rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(rewards, batch_rewards[:, i], rtol=1e-12, atol=1e-12)
    single_scores.sort(key=lambda s: s[0])
    batch_scores.sort(key=lambda s: s[0])
    assert len(single_scores) == len(batch_scores) >= 2 * n
    for (i, p1, s1), (j, p2, s2) in zip(single_scores, batch_scores):
        assert i == j and s1 == s2 and p1 == pytest.approx(p2, rel=1e-9)
