"""The JAX PPO: a smoke run of two seeds in one ``vmap``, its export played in NumPy exactly as the
JAX actor acts, and ``train_jax.py``'s refusals (the learning goal itself is measured by
``train_jax.py``, not here: docs/learners.md)."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("optax")

import jax.numpy as jnp  # noqa: E402

import sail_env.jax  # noqa: E402
from agents.jax_ppo import PPOConfig, _mlp, actor_arrays, init_network, make_train  # noqa: E402
from agents.mlp_policy import MlpPolicyAgent, save_policy  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def test_two_seeds_train_in_one_vmap_and_the_export_acts_as_the_actor(tmp_path: Path) -> None:
    env, params = sail_env.jax.make("LightSail-v0")
    config = PPOConfig(total_timesteps=2048, num_envs=16, num_steps=32, num_minibatches=4, update_epochs=2)
    out = jax.jit(jax.vmap(make_train(env, params, config)))(jax.random.split(jax.random.key(0), 2))
    assert out["metrics"]["reward"].shape == (2, config.num_updates)
    assert bool(jnp.all(jnp.isfinite(out["metrics"]["reward"])))
    first, second = (jax.tree.map(lambda a: np.asarray(a)[row], out["network"]) for row in (0, 1))
    assert not np.array_equal(first["actor"][0]["w"], second["actor"][0]["w"])  # the seeds differ
    save_policy(tmp_path / "policy.npz", actor_arrays(first), {"env_id": "LightSail-v0", "algo": "jax_ppo"})
    agent = MlpPolicyAgent(tmp_path / "policy.npz")
    obs = np.random.default_rng(1).normal(size=(50, 5)).astype(np.float32)
    expected = np.clip(np.asarray(_mlp(first["actor"], jnp.asarray(obs))), -1, 1)
    np.testing.assert_allclose(agent.act(obs), expected, rtol=1e-5, atol=1e-6)
    with pytest.raises(ValueError, match="observations of size 5"):
        agent.act(np.zeros(25))


def test_bad_settings_are_refused_naming_them() -> None:
    with pytest.raises(ValueError, match="num_minibatches"):
        PPOConfig(num_envs=3, num_steps=3, num_minibatches=2)
    with pytest.raises(ValueError, match="gamma"):
        PPOConfig(gamma=1.5)
    assert dataclasses.replace(PPOConfig(), total_timesteps=10**6).num_updates == 10**6 // 4096


@pytest.mark.parametrize("argv, message", [(["--env", "LightSailUncertain-v2"], "JAX backend has"),
                                           (["--seeds", "0"], "--seeds"), (["-n", "10"], "total_timesteps")])
def test_train_jax_refuses_in_one_line_and_writes_nothing(tmp_path: Path, argv: list[str], message: str) -> None:
    done = subprocess.run([sys.executable, "train_jax.py", *argv, "--runs-dir", str(tmp_path / "runs")], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and message in done.stderr, done.stderr
    assert not (tmp_path / "runs").exists()


def test_evaluate_reports_a_jax_policy_beside_the_baselines(tmp_path: Path) -> None:
    """``evaluate.py --agent …/policy.npz`` plays the exported actor on the Gym env (no JAX there)."""
    network = jax.tree.map(np.asarray, init_network(jax.random.key(0), 5, 2, PPOConfig()))
    run = tmp_path / "runs" / "LightSail-v0-jax_ppo-0"
    run.mkdir(parents=True)
    save_policy(run / "policy.npz", actor_arrays(network), {"env_id": "LightSail-v0", "algo": "jax_ppo"})
    done = subprocess.run([sys.executable, "evaluate.py", "--agent", "passive", "--agent", str(run / "policy.npz"),
                           "--episodes", "4", "--out", str(tmp_path / "report")], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    report = json.loads((tmp_path / "report" / "report.json").read_text())
    assert "LightSail-v0-jax_ppo-0" in json.dumps(report)
    refused = subprocess.run([sys.executable, "evaluate.py", "--env", "LightSailRealistic-v0", "--agent",
                              str(run / "policy.npz"), "--episodes", "1", "--out", str(tmp_path / "other")], cwd=ROOT,
                             capture_output=True, text=True, timeout=300)
    assert refused.returncode == 2 and "observations of size 5" in refused.stderr and refused.stderr.count("\n") == 1
