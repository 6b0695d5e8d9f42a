"""The JAX backend's interface: gymnax's API with autoreset, params per environment, a jitted
``lax.scan`` rollout, clear refusals, and ``import sail_env`` without JAX."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("gymnax")

import jax.numpy as jnp  # noqa: E402

import sail_env.jax  # noqa: E402


def test_import_sail_env_never_imports_jax() -> None:
    check = "import sail_env, sail_env.envs.planar, sail_env.envs.rigid3d, agents, sys; print('jax' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"


def test_step_autoresets_and_reports_the_score_at_the_end() -> None:
    env, params = sail_env.jax.make("LightSail-v0")
    obs, state = env.reset(jax.random.key(0), params)
    assert obs.shape == env.observation_space(params).shape == (5,) and obs.dtype == jnp.float32
    assert env.action_space(params).shape == (2,)
    for t in range(params.max_steps_in_episode):
        last_obs = obs
        obs, state, reward, terminated, truncated, info = env.step(jax.random.key(t + 1), state, jnp.zeros(2), params)
        assert not truncated
        assert bool(terminated) == (t == params.max_steps_in_episode - 1)
    # The passive sail keeps oscillating: scored, not successful; the state is the next episode's.
    assert np.isfinite(info["terminal_pointing_rad"]) and info["terminal_pointing_rad"] > 1e-8
    assert not info["is_success"] and not info["diverged"]
    assert int(state.time) == 0 and float(obs[-1]) == -1.0
    assert float(info["final_observation"][-1]) == 1.0 and not np.array_equal(info["final_observation"], last_obs)


def test_each_environment_can_have_its_own_params() -> None:
    """``vmap`` over a batch of params (domain randomisation): each environment plays what a
    single env with its params plays."""
    env, wide = sail_env.jax.make("LightSail-v0")
    _, narrow = sail_env.jax.make("LightSail-v0", max_beam_offset_m=0.005)
    batch = jax.tree.map(lambda a, b: jnp.stack([a, b]), wide, narrow)
    launch = jnp.asarray([[1e-3, 0.05, 1e-3, 0.0]] * 2)
    action = jnp.asarray([[0.7, -0.3]] * 2)
    starts = jax.vmap(env.draw_start, in_axes=(None, 0, 0))(jax.random.key(0), batch, launch)
    _, states = jax.vmap(env.reset_from)(starts, batch)
    obs, _, reward, _, _ = jax.vmap(env.step_env, in_axes=(None, 0, 0, 0))(jax.random.key(0), states, action, batch)
    for row, params in enumerate((wide, narrow)):
        _, single = env.reset_from(env.draw_start(jax.random.key(0), params, launch[row]), params)
        alone, _, alone_reward, _, _ = env.step_env(jax.random.key(0), single, action[row], params)
        np.testing.assert_array_equal(obs[row], alone)
        assert reward[row] == alone_reward
    assert not np.array_equal(obs[0], obs[1])


def test_a_jitted_scan_rolls_out_many_environments() -> None:
    env, params = sail_env.jax.make("LightSailDeepDish-v0")
    envs, steps = 64, 450

    def rollout(key):
        obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(key, envs), params)

        def one(carry, key):
            state, obs = carry
            step_key, act_key = jax.random.split(key)
            action = jax.random.uniform(act_key, (envs, 2), minval=-1.0, maxval=1.0)
            obs, state, reward, terminated, _, info = jax.vmap(env.step, in_axes=(0, 0, 0, None))(
                jax.random.split(step_key, envs), state, action, params)
            return (state, obs), (reward, terminated, info["is_success"])

        return jax.lax.scan(one, (state, obs), jax.random.split(key, steps))[1]

    reward, terminated, success = jax.jit(rollout)(jax.random.key(3))
    assert reward.shape == (steps, envs) and bool(jnp.all(jnp.isfinite(reward)))
    assert int(terminated.sum()) == 2 * envs  # every environment ended two 200-step windows
    assert int(success.sum()) <= int(terminated.sum())


@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSailRealistic-v0"])
def test_the_batched_step_is_vmapped_step(env_id: str) -> None:
    """``step_batch`` gates the coast and the resets on the batch but plays what ``vmap(step)`` plays,
    to the bit, through two windows with autoreset (and a few early divergences)."""
    env, params = sail_env.jax.make(env_id, draws=64)
    envs, steps = 260, 410  # more than one chunk of step_batch's gathering on any platform (CHUNK)

    def rollout(batched: bool):
        def run(key):
            _, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(key, envs), params)

            def one(state, key):
                act_key, step_key = jax.random.split(key)
                action = jax.random.uniform(act_key, (envs, 2), minval=-1.5, maxval=1.5)
                keys = jax.random.split(step_key, envs)
                step = env.step_batch if batched else jax.vmap(env.step, in_axes=(0, 0, 0, None))
                obs, state, reward, terminated, _, info = step(keys, state, action, params)
                return state, (obs, reward, terminated, info["terminal_pointing_rad"], info["final_observation"])

            return jax.lax.scan(one, state, jax.random.split(key, steps))[1]
        return jax.jit(run)(jax.random.key(5))

    for batched, alone in zip(rollout(True), rollout(False)):
        np.testing.assert_array_equal(np.asarray(batched), np.asarray(alone))
    assert int(rollout(True)[2].sum()) >= 2 * envs


def test_tasks_the_backend_does_not_carry_are_refused() -> None:
    with pytest.raises(ValueError, match="light delay without noise"):
        sail_env.jax.make("LightSail-v0", light_delay=True)
    with pytest.raises(ValueError, match="parameter_spread without noise"):
        sail_env.jax.make("LightSailDeepDish-v0", parameter_spread=0.05)
    with pytest.raises(ValueError, match="draws must be >= 1"):
        sail_env.jax.make("LightSailRealistic-v0", draws=0)
    with pytest.raises(ValueError, match="a coast along the flight the plant does not hand over"):
        sail_env.jax.make("LightSail3D-v0", dust_density_m3=1e-3, dust_grain_mass_kg=2e-27)  # dust, no flight table
    with pytest.raises(ValueError, match="power control"):
        sail_env.jax.make("LightSail3D-v0", power_control=True)
    with pytest.raises(ValueError, match="no task 'CartPole-v1'"):
        sail_env.jax.make("CartPole-v1")
    with pytest.raises(ValueError, match="no task 'CartPole-v1'"):
        sail_env.jax.make("CartPole-v1")
    with pytest.raises(ValueError, match="max_beam_offset_m"):
        sail_env.jax.make("LightSail-v0", max_beam_offset_m=-1.0)
    for draws in (1e4, "64", True):  # NumPy's TypeErrors named nothing
        with pytest.raises(ValueError, match=r"^draws must be an int >= 1"):
            sail_env.jax.make("LightSailRealistic-v0", draws=draws)


def test_an_out_of_date_id_warns_as_gym_make_does() -> None:
    with pytest.warns(UserWarning, match="LightSailUncertain-v0 is out of date: its latest version is LightSailUncertain-v2"):
        sail_env.jax.warn_if_out_of_date("LightSailUncertain-v0")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sail_env.jax.warn_if_out_of_date("LightSailUncertain-v2")
        sail_env.jax.make("LightSail-v0")


def test_gymnasium_functional_envs_play_the_same_episodes() -> None:
    """``gym.make("jax/LightSail-v0")`` and its vector env are Gymnasium's functional wrappers over
    the same functions: the same key gives the same episode as gymnax's API."""
    import gymnasium as gym

    env = gym.make("jax/LightSail-v0")
    assert env.unwrapped.metadata["jax"] is True
    obs, _ = env.reset(seed=7)
    assert env.observation_space.contains(np.asarray(obs))
    total, steps, terminated = 0.0, 0, False
    while not terminated:
        obs, reward, terminated, truncated, info = env.step(np.array([0.1, -0.1], dtype=np.float32))
        total, steps = total + reward, steps + 1
    assert steps == 200 and np.isfinite(info["terminal_pointing_rad"]) and "is_success" in info
    envs = gym.make_vec("jax/LightSail-v0", num_envs=8)
    obs, _ = envs.reset(seed=0)
    obs, reward, terminated, truncated, info = envs.step(np.zeros((8, 2), dtype=np.float32))
    assert obs.shape == (8, 5) and reward.shape == (8,) and not bool(np.any(terminated))
    with pytest.raises(ValueError, match="render_mode"):
        gym.make("jax/LightSail-v0", render_mode="human")


def test_the_functional_envs_refuse_what_they_cannot_play() -> None:
    """Gymnasium's route refuses, as the Numba envs do, a step after the episode's end (it played steps
    201–203 and scored them again), actions of another shape (broadcast) or not finite; its vector env
    resets an ended episode on the next step (it crashed there, indexing the state as one array)."""
    import gymnasium as gym

    env = gym.make("jax/LightSail-v0")
    env.reset(seed=0)
    for bad, message in ((np.zeros(1), r"shape \(2,\)"), (0.5, r"shape \(2,\)"), (np.array([np.nan, 0.0]), "finite")):
        with pytest.raises(ValueError, match=message):
            env.step(bad)
    for _ in range(200):
        *_, terminated, _, info = env.step(np.zeros(2, np.float32))
    assert terminated
    with pytest.raises(RuntimeError, match="finished episode"):
        env.step(np.zeros(2, np.float32))
    from gymnasium.utils.env_checker import check_env

    check_env(gym.make("jax/LightSail-v0").unwrapped)  # its determinism check failed on the NaN scores before the end
    env.reset(seed=0)
    assert set(env.step(np.zeros(2, np.float32))[-1]) == {"envelope_rad"}  # the scores come at the end, as the Gym env's
    envs = gym.make_vec("jax/LightSail-v0", num_envs=3)
    envs.reset(seed=1)
    for step in range(202):
        obs, reward, terminated, _, _ = envs.step(np.zeros((3, 2), np.float32))
        assert bool(np.all(terminated)) == (step == 199), step
    assert float(obs[0, -1]) == np.float32(-1.0 + 2 / 200) and np.all(np.isfinite(np.asarray(obs)))  # one step into the next
    for num_envs in (0, -1):
        with pytest.raises(ValueError, match="num_envs must be an int >= 1"):
            gym.make_vec("jax/LightSail-v0", num_envs=num_envs)


def test_a_coast_along_the_flight_plays_in_float32() -> None:
    """``make(..., dtype=float32)`` on a task whose coast follows the flight (its reset failed: float64
    crept into the scan's carry from the noise's generator, the payload's torque and the impacts)."""
    env, params = sail_env.jax.make("LightSailUncertain-v2", dtype=jnp.float32, draws=8)

    def one(state: object, key: jax.Array) -> tuple:
        _, state, reward, _, _, info = env.step(key, state, jnp.zeros(env.num_actions, jnp.float32), params)
        return state, (reward, info["terminal_pointing_rad"])

    _, state = env.reset(jax.random.key(0), params)
    keys = jax.random.split(jax.random.key(1), params.max_steps_in_episode)
    state, (reward, pointing) = jax.jit(lambda s: jax.lax.scan(one, s, keys))(state)
    assert state.x.dtype == reward.dtype == jnp.float32
    assert 1e-10 < float(pointing[-1]) < 1e-5  # scored at cut-off, finite


def test_params_of_another_variant_and_actions_of_another_shape_are_refused() -> None:
    """gymnax's route: params made with a noise the env does not draw (they played noise-free), and an
    action of another shape (JAX broadcast it), each one ValueError, under ``jit`` too."""
    env, params = sail_env.jax.make("LightSail-v0")
    _, noisy = sail_env.jax.make("LightSail-v0", sensor_noise_std=(1e-2, 1e-2, 1e-3, 1e-6))
    key = jax.random.key(0)
    with pytest.raises(ValueError, match=r"^params: made for another variant of the task \(sensor_noise_std True"):
        env.reset(key, noisy)
    _, state = env.reset(key, params)
    with pytest.raises(ValueError, match="another variant"):
        env.step(key, state, jnp.zeros(2), noisy)
    for action in (jnp.full((1,), 0.5), jnp.asarray(0.5)):
        with pytest.raises(ValueError, match=r"action must have shape \(2,\)"):
            jax.jit(env.step)(key, state, action, params)


def test_speed_jax_writes_its_table_between_the_markers(tmp_path) -> None:
    from benchmarks import speed_jax

    doc = tmp_path / "performance.md"
    doc.write_text("before\n<!-- jax-speed-table:start -->\nold\n<!-- jax-speed-table:end -->\nafter\n")
    assert speed_jax.main(["--sizes", "64", "--tasks", "LightSail-v0", "--rounds", "1", "--steps", "4",
                            "--readme", str(doc)]) == 0
    text = doc.read_text()
    assert "old" not in text and text.startswith("before\n") and text.endswith("after\n")
    assert "| LightSail-v0 | 64 |" in text and "first step of `LightSail-v0`" in text
    assert "LightSail3D-v0" not in text  # only the tasks asked for
    for argv in (["--sizes", "0"], ["--rounds", "0"], ["--fast-coast", "8", "--tasks", "LightSail-v0"]):
        assert speed_jax.main([*argv, "--readme", str(doc)]) == 2  # one line, nothing measured or written
    assert doc.read_text() == text


def test_gather_chunk_times_each_size_on_the_same_episodes_and_restores_the_setting(tmp_path) -> None:
    from benchmarks import gather_chunk
    from sail_env.jax import env as jax_env

    kept, out = dict(jax_env.CHUNK), tmp_path / "chunk.json"
    assert gather_chunk.main(["--env", "LightSail-v0", "--envs", "16", "--chunks", "2", "16", "--rounds", "1",
                              "--out", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert [(row["case"], row["chunk"]) for row in rows] == [("spread", 2), ("spread", 16), ("together", 2),
                                                             ("together", 16)]
    assert all(row["rate"] > 0 for row in rows) and jax_env.CHUNK == kept
    # The chunk size changes the cost, never the episodes: the same number ended either way.
    assert rows[0]["episodes_ended"] == rows[1]["episodes_ended"] > 0
    assert rows[2]["episodes_ended"] == rows[3]["episodes_ended"] >= 16


def test_the_readmes_jax_example_prints_what_it_says() -> None:
    import re
    from pathlib import Path

    section = (Path(__file__).resolve().parents[2] / "README.md").read_text().split("## The JAX backend", 1)[1]
    code = re.findall(r"```python\n(.*?)```", section, flags=re.S)[0]
    printed = re.search(r"prints `(.*?)`", section).group(1)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == printed


def test_an_empty_batch_steps_to_empty_arrays() -> None:
    """``step_batch`` at N = 0 (it divided by a chunk of size zero, and ``speed_jax --sizes 0`` with it)."""
    env, params = sail_env.jax.make("LightSail-v0")
    keys = jax.random.split(jax.random.key(0), 0)
    _, state = jax.vmap(env.reset, in_axes=(0, None))(keys, params)
    obs, _, reward, terminated, _, _ = env.step_batch(keys, state, jnp.zeros((0, 2)), params)
    assert obs.shape == (0, 5) and reward.shape == terminated.shape == (0,)
