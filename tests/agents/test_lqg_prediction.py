"""LQG's delay compensation against the sail's true flight: without noise and on the nominal
model, the state the filter predicts for the step its command reaches the sail is the state the
sail then has, so each command is the LQR law on that future true state."""

import gymnasium as gym
import numpy as np

import sail_env  # noqa: F401
from agents import LQGAgent
from sail_env.physics import DEEP_DISH


def test_lqg_commands_act_on_the_state_at_their_arrival():
    env = gym.make("LightSail-v0", config=DEEP_DISH.replace(control_start_s=10.0), light_delay=True)
    spec = env.unwrapped.episode_spec
    agent = LQGAgent(spec)
    obs, info = env.reset(seed=3)
    states, commands = [list(info["state"].values())], []
    for step in range(spec.n_steps):
        action = agent.act(obs)
        commands.append(agent.sent[-1][0] if agent.sent[-1].ndim > 1 else agent.sent[-1])
        obs, _, terminated, _, info = env.step(action)
        states.append(list(info["state"].values()))
        if terminated:
            break
    states, commands = np.array(states), np.array(commands)
    arrivals = np.arange(len(commands)) + spec.delay_steps(np.arange(len(commands)))
    assert arrivals.max() > len(commands) - 1 and spec.delay_steps(0) >= 3  # the delay is real
    reachable = arrivals < len(states)
    expected = np.clip(-states[arrivals[reachable]] @ agent.gain.T, -spec.action_scale, spec.action_scale)
    assert np.abs(expected).max() > 0.1 * spec.action_scale.max()  # the commands are not trivially zero
    np.testing.assert_allclose(commands[reachable], expected, rtol=0, atol=1e-6 * np.abs(expected).max())
