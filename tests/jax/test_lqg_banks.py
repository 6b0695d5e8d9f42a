"""The JAX LQG policies (:mod:`agents.jax_policies`) action for action against their NumPy agents.

A NumPy agent plays whole episodes of a NumPy env (each runs to its termination at the window's end,
200 steps); the JAX policy, fed the same observations (one ``lax.scan`` per episode, the episodes
``vmap``-ped), must send the same commands: float64, within :data:`TOLERANCE` of the action scale
(measured: 2.1e-15 at most, on the uncertain task's offset-free bank), the same float32 actions (measured:
equal; one float32 rounding apart is allowed, for commands that straddle a boundary), and for a bank
the same member at every step. Each bank's episodes switch the chosen member (asserted, so that the
choice is tested). Mutants the test catches: every member on the nominal delay (every bank case), each
member predicting through its own commands instead of the chosen one (every bank case), the filter
started from zero instead of the measurement (every case), the score without forgetting (three of the
four bank cases) or of the latest cost alone (every bank case), the commands not subtracting the
offset estimate (both offset-free banks)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

jax = pytest.importorskip("jax")

import jax.numpy as jnp  # noqa: E402

import sail_env  # noqa: F401, E402  (registers the env ids)
from agents.adaptive import MultipleModelLQGAgent  # noqa: E402
from agents.evaluation import BASELINES  # noqa: E402
from agents.jax_policies import POLICIES  # noqa: E402

#: Largest difference of a command [SI] from the NumPy agent's, in units of the action scale.
TOLERANCE = 1e-9
#: Their episodes switch each bank's chosen member 1 to 20 times.
SEEDS = (0, 1)
CASES = [("LightSail3DRealistic-v1", "lqg"), ("LightSail3DRealistic-v1", "lqg-mm"),
         ("LightSail3DRealistic-v1", "lqg-mm-offset"), ("LightSailUncertain-v2", "lqg-mm"),
         ("LightSailUncertain-v2", "lqg-mm-offset")]


def _numpy_episode(env: gym.Env, agent_name: str, seed: int) -> dict[str, np.ndarray]:
    """One episode of the NumPy agent: the observations it saw, its float64 commands and float32 actions,
    and for a bank the member it chose, step by step."""
    agent = BASELINES[agent_name](env.unwrapped.episode_spec)
    sender = agent.bank[0] if isinstance(agent, MultipleModelLQGAgent) else agent  # holds the commands sent
    obs, _ = env.reset(seed=seed)
    record: dict[str, list] = {"obs": [], "command": [], "action": [], "choice": []}
    terminated = truncated = False
    while not (terminated or truncated):
        action = agent.act(obs)
        record["obs"].append(obs)
        record["command"].append(sender.last_command[0].copy())
        record["action"].append(action)
        record["choice"].append(agent.choice[0] if isinstance(agent, MultipleModelLQGAgent) else 0)
        obs, _, terminated, truncated, _ = env.step(action)
    assert terminated, f"seed {seed}: truncated"
    return {key: np.array(value) for key, value in record.items()}


@pytest.mark.parametrize(("env_id", "agent_name"), CASES)
def test_jax_policy_sends_the_numpy_agents_commands(env_id: str, agent_name: str) -> None:
    env = gym.make(env_id)
    spec = env.unwrapped.episode_spec
    episodes = [_numpy_episode(env, agent_name, seed) for seed in SEEDS]
    steps = len(episodes[0]["obs"])
    assert all(len(e["obs"]) == steps == spec.n_steps for e in episodes)  # each ended at the window's end
    policy = POLICIES[agent_name](spec)

    def episode(observations: jax.Array) -> tuple[dict, jax.Array, jax.Array]:
        def one(memory: dict, observation: jax.Array) -> tuple[dict, tuple[jax.Array, jax.Array]]:
            memory, action = policy.act(memory, observation)
            # A bank's chosen member: its lowest score (the LQG, no score: its one member).
            return memory, (action, jnp.argmin(memory.get("score", jnp.zeros(1))))

        memory, (actions, choices) = jax.lax.scan(one, policy.start(), observations)
        return memory["sent"][:steps], actions, choices

    commands, actions, choices = jax.jit(jax.vmap(episode))(jnp.asarray(np.stack([e["obs"] for e in episodes])))
    for k, numpy in enumerate(episodes):
        if agent_name != "lqg":
            assert np.any(np.diff(numpy["choice"]) != 0), f"seed {SEEDS[k]}: the bank never switched"
        np.testing.assert_array_equal(np.asarray(choices[k]), numpy["choice"])
        difference = np.abs(np.asarray(commands[k]) - numpy["command"]) / spec.action_scale
        assert difference.max() <= TOLERANCE, (SEEDS[k], difference.max())
        # float32 actions: equal, or one rounding apart where the commands straddle a float32 boundary.
        np.testing.assert_allclose(np.asarray(actions[k]), numpy["action"], rtol=0, atol=2 ** -23)
