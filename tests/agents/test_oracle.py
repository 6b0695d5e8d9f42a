"""The ceiling agents (agents/oracle.py): they read the episode's true draw, and act on it as designed."""

import gymnasium as gym
import numpy as np
import pytest
import scipy.linalg

import sail_env  # noqa: F401
from agents import LQGAgent
from agents.lqr import lqr_gain, state_weights
from agents.oracle import OracleLQGAgent, OracleLQRAgent, attach, episode_truth
from agents.evaluation import paired_difference
from sail_env.physics import DEEP_DISH
from sail_env.physics.linear import LinearModel

#: Delayed, noise-free, with a ±10 % draw and a payload's constant term: the truth is all there is.
SPREAD_3D = ("LightSail3D-v0", {"curvature_radius_m": 4.0, "absorptivity": 0.1, "control_start_s": 10.0,
                                "light_delay": True, "payload_offset_m": 5e-3, "parameter_spread": 0.1})
SPREAD_PLANAR = ("LightSail-v0", {"config": DEEP_DISH.replace(control_start_s=10.0), "light_delay": True,
                                  "parameter_spread": 0.1})


@pytest.mark.parametrize("task", [SPREAD_3D, SPREAD_PLANAR])
def test_truth_is_the_step_the_env_takes(task):
    """``episode_truth``'s ``(A, B, c)`` stepped exactly (scipy's expm of ``[[A, B, c], 0]``) is the env's
    next state, and it is the draw's, not the nominal model."""
    env = gym.make(task[0], **task[1])
    env.reset(seed=11)
    truth = episode_truth(env)
    m = truth.b.shape[2]
    u = np.linspace(-0.5, 0.5, m) * env.unwrapped.episode_spec.action_scale
    n = truth.a.shape[1]
    block = np.zeros((n + m + 1, n + m + 1))
    block[:n, :n], block[:n, n:n + m], block[:n, -1] = truth.a[0], truth.b[0], truth.constant[0]
    exact = scipy.linalg.expm(block * env.unwrapped.dt)
    # Send u long enough that it acts (the delay), then compare one step.
    spec = env.unwrapped.episode_spec
    action = spec.input_to_action(u)
    u = action.astype(float) * spec.action_scale  # the float32 action the env receives
    for _ in range(int(spec.delay_steps(0, truth.acceleration[0])) + 2):
        env.step(action)
    before = episode_truth(env).state[0]
    env.step(action)
    after = episode_truth(env).state[0]
    expected = exact[:n, :n] @ before + exact[:n, n:n + m] @ u + exact[:n, -1]
    np.testing.assert_allclose(after, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())
    assert np.abs(truth.a[0] - spec.nominal.A).max() > 1e-3 * np.abs(spec.nominal.A).max()


@pytest.mark.parametrize("task", [SPREAD_3D, SPREAD_PLANAR])
def test_oracle_lqr_commands_the_drawn_lqr_on_the_state_at_arrival(task):
    """Noise-free, each command is the LQR law of the episode's own drawn model applied to the true
    state its command meets (the prediction with the draw's delay is exact); the nominal gain is not."""
    env = gym.make(task[0], **task[1])
    spec = env.unwrapped.episode_spec
    agent = OracleLQRAgent(spec)
    attach(agent, env)
    obs, info = env.reset(seed=4)
    agent.reset()
    truth = episode_truth(env)
    gain = lqr_gain(LinearModel(truth.a[0], truth.b[0]), spec.dt, spec.state_scale, spec.action_scale,
                    weights=state_weights(spec))
    states, commands = [episode_truth(env).state[0]], []
    for _ in range(spec.n_steps):
        obs, _, terminated, _, _ = env.step(agent.act(obs))
        commands.append(agent.last_command[0])
        states.append(episode_truth(env).state[0])
        if terminated:
            break
    states, commands = np.array(states), np.array(commands)
    steps = np.arange(len(commands))
    arrivals = steps + spec.delay_steps(steps, truth.acceleration[0])
    reachable = arrivals < len(states)
    expected = np.clip(-states[arrivals[reachable]] @ gain.T, -spec.action_scale, spec.action_scale)
    assert np.abs(expected).max() > 0.1 * spec.action_scale.max()
    np.testing.assert_allclose(commands[reachable], expected, rtol=0, atol=1e-6 * np.abs(expected).max())
    nominal = lqr_gain(spec.nominal, spec.dt, spec.state_scale, spec.action_scale, weights=state_weights(spec))
    assert np.abs(nominal - gain).max() > 1e-3 * np.abs(gain).max()


def test_oracle_lqg_is_lqg_when_nothing_is_drawn():
    """Without a parameter spread the drawn model is the nominal one: the oracle LQG plays LQG's commands."""
    envs = gym.make_vec("LightSail3DRealistic-v1", num_envs=4, vectorization_mode="vector_entry_point",
                        parameter_spread=0.0)
    spec = envs.unwrapped.episode_spec
    oracle, lqg = OracleLQGAgent(spec), LQGAgent(spec)
    attach(oracle, envs)
    obs, _ = envs.reset(seed=2)
    oracle.reset()
    lqg.reset()
    for _ in range(40):
        action = lqg.act(obs)
        np.testing.assert_array_equal(oracle.act(obs), action)
        obs, *_ = envs.step(action)


def test_oracle_lqg_designs_on_each_draw():
    envs = gym.make_vec(*SPREAD_3D[:1], num_envs=3, vectorization_mode="vector_entry_point", **SPREAD_3D[1])
    oracle = OracleLQGAgent(envs.unwrapped.episode_spec)
    attach(oracle, envs)
    envs.reset(seed=0)
    oracle.reset()
    truth = episode_truth(envs)
    assert oracle.design.gain.shape[0] == 3
    for i in range(3):
        np.testing.assert_allclose(oracle.design.phi[i], scipy.linalg.expm(truth.a[i] * oracle.spec.dt), rtol=1e-9,
                                   atol=1e-12)


def test_oracle_refuses_to_act_without_the_env():
    agent = OracleLQRAgent(gym.make("LightSail-v0").unwrapped.episode_spec)
    with pytest.raises(RuntimeError, match="attach"):
        agent.act(np.zeros(5, dtype=np.float32))
    with pytest.raises(ValueError, match="states"):
        agent.attach(gym.make("LightSail3D-v0"))


def test_an_oracle_refuses_to_act_unless_attached_and_reset():
    """Unattached, lqg-oracle played the nominal LQG under the oracle's name (lqr-oracle refused)."""
    env = gym.make("LightSail-v0")
    obs, _ = env.reset(seed=0)
    for oracle in (OracleLQGAgent(env.unwrapped.episode_spec), OracleLQRAgent(env.unwrapped.episode_spec)):
        with pytest.raises(RuntimeError, match="attach"):
            oracle.act(obs)
        attach(oracle, env)
        with pytest.raises(RuntimeError, match=r"reset\(\) after attach"):  # still the nominal design
            oracle.act(obs)
        oracle.reset()
        assert oracle.act(obs).shape == (2,)


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_an_oracle_refuses_a_vector_env_that_hides_its_episode_state(mode):
    """Gymnasium's one-env-at-a-time vector envs: an AttributeError from deep inside, now one ValueError."""
    envs = gym.make_vec("LightSail-v0", num_envs=2, vectorization_mode=mode)
    try:
        for oracle in (OracleLQGAgent, OracleLQRAgent):
            with pytest.raises(ValueError, match="vector_entry_point"):
                attach(oracle(gym.make("LightSail-v0").unwrapped.episode_spec), envs)
    finally:
        envs.close()


def test_paired_difference_counts_and_interval():
    """12 episodes: A wins 4 where the reference loses, loses 1: +25 points, McNemar p = 0.375 (2 × 5/32)."""
    a = np.array([1, 1, 1, 1, 0, 1, 1, 0, 0, 1, 1, 1], bool)
    r = np.array([0, 0, 0, 0, 1, 1, 1, 0, 0, 1, 1, 1], bool)
    out = paired_difference(a, r)
    assert (out["wins"], out["losses"]) == (4, 1)
    assert out["difference"] == pytest.approx(3 / 12)
    assert out["mcnemar_p"] == pytest.approx(0.375)
    assert out["ci95"][0] < 0.25 < out["ci95"][1]
    assert paired_difference(r, a)["difference"] == pytest.approx(-0.25)
    with pytest.raises(ValueError, match="over the reference's"):
        paired_difference(a, r[:5])


def test_paired_difference_of_several_seeds_compares_their_mean():
    """Two seeds' successes (their mean per episode: 1, 0.5, 0, 0.5) against a reference of
    (1, 1, 0, 0): +0 on average; no McNemar test (it is for one run's booleans)."""
    seeds = np.array([[1, 1, 0, 0], [1, 0, 0, 1]], bool)
    out = paired_difference(seeds, np.array([1, 1, 0, 0], bool))
    assert out["difference"] == pytest.approx(0.0) and "mcnemar_p" not in out
    assert out["ci95"][0] < 0 < out["ci95"][1]
    assert paired_difference(seeds[:1], np.ones(4, bool))["difference"] == pytest.approx(-0.5)


def test_paired_difference_of_probabilities_has_no_mcnemar_test():
    """The expected success (each episode's probability): the mean difference, and no McNemar test."""
    out = paired_difference(np.array([0.5, 0.25, 1.0]), np.array([0.0, 0.25, 0.75]))
    assert out["difference"] == pytest.approx(0.25) and "mcnemar_p" not in out
