"""The multiple-model adaptive LQG (agents/adaptive.py): its plumbing is LQG's, and it finds the model."""

import gymnasium as gym
import numpy as np
import pytest
import scipy.linalg

import sail_env  # noqa: F401
import agents.adaptive as adaptive
from agents import LQGAgent
from agents.adaptive import MultipleModelLQGAgent, model_grid
from agents.oracle import episode_truth
from sail_env.physics.rigid3d.uncertainty import ModelUncertainty

#: Noise-free, delayed, with the uncertain task's draws (a cheap flight: no relativity, no diffraction).
QUIET = {"curvature_radius_m": 4.0, "absorptivity": 0.1, "beam_profile": "gaussian", "beam_radius_m": 1.6,
         "spin_rad_s": 1.0, "control_start_s": 10.0, "light_delay": True, "payload_offset_m": 5e-3,
         "start_half_widths": (3e-2, 3e-2, 0.6, 0.6, 2e-3, 2e-3, 1e-5, 1e-5),
         "model_uncertainty": ModelUncertainty(curvature=0.2, absorptivity=0.5, power=0.2)}


def test_a_bank_of_the_nominal_model_is_lqg(monkeypatch):
    monkeypatch.setattr(adaptive, "STIFFNESS_GRID", (1.0,))
    monkeypatch.setattr(adaptive, "CURVATURE_GRID", (1.0,))
    envs = gym.make_vec("LightSail3D-v0", num_envs=3, vectorization_mode="vector_entry_point", **QUIET)
    spec = envs.unwrapped.episode_spec
    bank, lqg = MultipleModelLQGAgent(spec), LQGAgent(spec)
    assert len(bank.bank) == 1
    obs, _ = envs.reset(seed=1)
    for _ in range(30):
        action = lqg.act(obs)
        np.testing.assert_array_equal(bank.act(obs), action)
        obs, *_ = envs.step(action)


@pytest.mark.parametrize("model", [0, 5, 8])
def test_the_bank_chooses_the_model_the_sail_flies(model):
    """The sail flies one of the bank's models, stepped here exactly (``expm`` of ``[[A, B, c], 0]``),
    observed without noise or delay; after 50 steps the bank acts with that model's loop."""
    spec = gym.make("LightSail3D-v0", **{**QUIET, "light_delay": False}).unwrapped.episode_spec
    agent = MultipleModelLQGAgent(spec)
    factors = np.array(model_grid(spec))
    assert len(factors) == 9
    p = spec.plant.params(factors[model:model + 1])
    n, m = p.a.shape[1], spec.plant.n_inputs
    block = np.zeros((n + m + 1, n + m + 1))
    block[:n, :n], block[:n, n:] = p.a[0], p.b[0]
    step = scipy.linalg.expm(block * spec.dt)
    x = np.random.default_rng(model).uniform(-1, 1, n) * np.array(QUIET["start_half_widths"])
    for _ in range(50):
        obs = np.zeros(spec.observation_size, dtype=np.float32)
        obs[:n] = x / spec.state_scale
        u = agent.act(obs).astype(float) * spec.action_scale
        x = step[:n, :n] @ x + step[:n, n:n + m] @ u + step[:n, -1]
    assert agent.choice.tolist() == [model]


def test_refuses_a_planar_task_and_bad_forgetting():
    with pytest.raises(ValueError, match="3D task"):
        MultipleModelLQGAgent(gym.make("LightSail-v0").unwrapped.episode_spec)
    with pytest.raises(ValueError, match="forgetting"):
        MultipleModelLQGAgent(gym.make("LightSail3D-v0", **QUIET).unwrapped.episode_spec, forgetting=1.0)


def test_the_offset_free_bank_estimates_the_beam_offset_and_cancels_it():
    """A pointing bias of up to 2 cm per axis (the uncertain task's draw, doubled): at the window's end the
    acting member's offset estimate is the drawn bias (read from the episode's true constant term, less
    the nominal one); predicting with it across the light delay saves the episode the plain bank loses
    (seed 2); subtracting it from the commands brings the sail back onto the beam's axis, where state
    feedback alone holds it off by the offset's push."""
    env = gym.make("LightSailUncertain-v1", model_uncertainty={"pointing_bias_m": 2e-2})
    spec = env.unwrapped.episode_spec
    worst, off_axis = {}, {}
    for offset_walk in (adaptive.OFFSET_WALK, 0.0):
        pointing, lateral = [], []
        for seed in range(4):
            obs, _ = env.reset(seed=seed)
            truth = episode_truth(env)
            bias = np.linalg.lstsq(truth.b[0][:, :2], truth.constant[0] - spec.plant.constant_term, rcond=None)[0]
            agent, done = MultipleModelLQGAgent(spec, offset_walk=offset_walk), False
            while not done:
                obs, _, terminated, truncated, info = env.step(agent.act(obs))
                done = terminated or truncated
            pointing.append(info["terminal_pointing_rad"])
            lateral.append(np.hypot(info["state"]["x"], info["state"]["y"]))
            if offset_walk:
                estimate = agent.bank[int(agent.choice[0])].estimate[0, spec.plant.n_states:]
                assert np.abs(bias).max() > 5e-3 and np.abs(estimate - bias).max() < 6e-4
        worst[offset_walk], off_axis[offset_walk] = max(pointing), np.mean(lateral)
    assert worst[adaptive.OFFSET_WALK] < 0.1 * worst[0.0]
    assert off_axis[adaptive.OFFSET_WALK] < 0.5 * off_axis[0.0]
