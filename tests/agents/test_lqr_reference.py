"""The LQR gain against an independent reference: the Riccati difference equation iterated to its
fixed point (value iteration), on the full state of a controllable task."""

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401
from agents import LQGAgent, LQRAgent, lqr_gain
from sail_env.physics.linear import LinearModel


def _value_iteration_gain(phi, gamma, q, r, tol=1e-13, max_iter=2_000_000):
    """``K`` of ``u = −K x`` from ``P ← Q + ΦᵀPΦ − ΦᵀPΓ (R + ΓᵀPΓ)⁻¹ ΓᵀPΦ`` run to convergence."""
    p = q.copy()
    for _ in range(max_iter):
        k = np.linalg.solve(r + gamma.T @ p @ gamma, gamma.T @ p @ phi)
        nxt = q + phi.T @ p @ (phi - gamma @ k)
        if np.max(np.abs(nxt - p)) <= tol * np.max(np.abs(nxt)):
            return k
        p = nxt
    raise AssertionError("value iteration did not converge")


@pytest.mark.parametrize("agent_cls", [LQRAgent, LQGAgent])
def test_agent_gain_is_the_value_iteration_fixed_point(agent_cls):
    """Weights (1, 10, 1, 1) on (X, Vx, θ, ω) and 1 on each input, in units of the observation and
    action scales (agents.lqr.STATE_WEIGHTS and INPUT_WEIGHT): both agents' default."""
    spec = gym.make("LightSailDeepDish-v0").unwrapped.episode_spec
    assert spec.nominal.is_controllable
    phi, gamma = spec.nominal.discretize(spec.dt)
    q = np.diag(np.array([1.0, 10.0, 1.0, 1.0]) / spec.state_scale**2)
    r = np.diag(1.0 / spec.action_scale**2)
    reference = _value_iteration_gain(phi, gamma, q, r)
    agent = agent_cls(spec)
    np.testing.assert_allclose(agent.gain, reference, rtol=1e-6, atol=1e-9 * np.abs(reference).max())
    # The same weights are lqr_gain's defaults.
    if agent_cls is LQRAgent:
        default = lqr_gain(spec.nominal, spec.dt, spec.state_scale, spec.action_scale)
        np.testing.assert_allclose(default, reference, rtol=1e-6, atol=1e-9 * np.abs(reference).max())


def test_lqr_gain_refuses_a_sail_the_beam_cannot_move():
    model = LinearModel(np.array([[0.0, 1.0], [-1.0, 0.0]]), np.zeros((2, 1)))
    with pytest.raises(ValueError, match="^the beam inputs cannot influence this sail: nothing to control$"):
        lqr_gain(model, 0.01, np.ones(2), np.ones(1), weights=np.ones(2))


def test_lqr_gain_on_a_one_dimensional_controllable_subspace_is_the_scalar_lqr():
    """``ẋ₁ = −x₁ + u``, ``ẋ₂ = −2 x₂`` (not reachable): the gain is the scalar discrete LQR's on x₁,
    from the closed-form root of its Riccati equation, and zero on x₂."""
    dt, q, r = 0.1, 3.0, 0.5
    model = LinearModel(np.diag([-1.0, -2.0]), np.array([[1.0], [0.0]]))
    gain = lqr_gain(model, dt, np.ones(2), np.ones(1), input_weight=r, weights=np.array([q, 5.0]))
    phi, gamma = np.exp(-dt), 1.0 - np.exp(-dt)
    # γ² p² + (r − q γ² − φ² r) p − q r = 0, the positive root.
    linear = r - q * gamma**2 - phi**2 * r
    p = (-linear + np.sqrt(linear**2 + 4 * gamma**2 * q * r)) / (2 * gamma**2)
    np.testing.assert_allclose(gain, [[gamma * p * phi / (r + gamma**2 * p), 0.0]], rtol=1e-10, atol=1e-12)
