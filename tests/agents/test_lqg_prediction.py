"""LQG's delay compensation against the sail's true flight: without noise and on the nominal
model, the state the filter predicts for the step its command reaches the sail is the state the
sail then has, so each command is the LQR law on that future true state."""

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401
from agents import LQGAgent
from sail_env.physics import DEEP_DISH
from sail_env.tasks import TASKS


PLANAR_DELAYED = ("LightSail-v0", {"config": DEEP_DISH.replace(control_start_s=10.0), "light_delay": True})
#: The 3D deep dish with a payload off its axis: the prediction must carry the constant term.
PAYLOAD_DELAYED = ("LightSail3D-v0", {"curvature_radius_m": 4.0, "absorptivity": 0.1, "control_start_s": 10.0,
                                      "light_delay": True, "payload_offset_m": 5e-3})


@pytest.mark.parametrize("task, start", [(PLANAR_DELAYED, None), (PLANAR_DELAYED, {"x": 0.2}), (PAYLOAD_DELAYED, None)])
def test_lqg_commands_act_on_the_state_at_their_arrival(task, start):
    """Also when the first commands saturate (a start 0.2 m off the beam): the filter predicts with
    the inputs the beam can give; and with a payload off the axis, with its constant torque."""
    env = gym.make(task[0], **task[1])
    spec = env.unwrapped.episode_spec
    agent = LQGAgent(spec)
    obs, info = env.reset(seed=3, options=None if start is None else {"initial_state": start})
    states, commands = [list(info["state"].values())], []
    for step in range(spec.n_steps):
        action = agent.act(obs)
        commands.append(agent.last_command[0])
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
    if start is not None:
        assert np.any(np.abs(expected) == spec.action_scale)
    np.testing.assert_allclose(commands[reachable], expected, rtol=0, atol=1e-6 * np.abs(expected).max())


def _steady_kalman_gain(phi, process, sensor, tol=1e-13, max_iter=2_000_000):
    """Gain of the filter ``x̂ += K (y − x̂)`` (the full state measured), from the covariance
    recursion ``P ← Φ (P − P (P + V)⁻¹ P) Φᵀ + W`` run to its fixed point."""
    p = process.copy()
    for _ in range(max_iter):
        gain = p @ np.linalg.inv(p + sensor)
        nxt = phi @ (p - gain @ p) @ phi.T + process
        if np.max(np.abs(nxt - p)) <= tol * np.max(np.abs(nxt)):
            return nxt @ np.linalg.inv(nxt + sensor)
        p = nxt
    raise AssertionError("covariance recursion did not converge")


@pytest.mark.parametrize("env_id, kwargs", [("LightSailRealistic-v0", {}),
                                            ("LightSailDeepDish-v0", {"beam_jitter_m": 1e-4, "push_noise": 0.02})])
def test_kalman_gain_is_the_covariance_recursion_fixed_point(env_id, kwargs):
    """Process noise per step: the beam jitter through Γ's offset column, the push noise through
    ``∂A/∂ln F`` over one step at the state scale, and a model-mismatch floor of 3e-3 state scales;
    sensor noise: the task's, floored at 1e-6 state scales (agents/lqg.py's docstring)."""
    spec = gym.make(env_id, **kwargs).unwrapped.episode_spec
    dist, scale = spec.randomisation, spec.state_scale
    phi, gamma = spec.nominal.discretize(spec.dt)
    kick = spec.nominal.push_sensitivity[0] @ scale * spec.dt
    jitter = {**TASKS[env_id], **kwargs}.get("beam_jitter_m", 0.0)
    process = (jitter**2 * np.outer(gamma[:, 0], gamma[:, 0]) + dist.push_noise**2 * np.outer(kick, kick)
               + np.diag((3e-3 * scale) ** 2))
    sensor = np.diag(np.maximum(np.array(dist.sensor_noise_std), 1e-6 * scale) ** 2)
    reference = _steady_kalman_gain(phi, process, sensor)
    np.testing.assert_allclose(LQGAgent(spec).kalman_gain, reference, rtol=1e-6, atol=1e-9)
