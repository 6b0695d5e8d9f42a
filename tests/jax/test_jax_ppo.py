"""The JAX PPO: a smoke run of two seeds in one ``vmap`` (the memoryless default as the code before
memory trained it), its export played in NumPy exactly as the JAX actor acts, the policies with memory
(history, GRU: their rollouts, resets and NumPy players), and ``train_jax.py``'s refusals (the learning
goal itself is measured by ``train_jax.py``, not here: docs/learners.md)."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

jax = pytest.importorskip("jax")
pytest.importorskip("optax")

import jax.numpy as jnp  # noqa: E402

import sail_env.jax  # noqa: E402
from agents.jax_ppo import (LOG_STD_RANGE, Memory, PPOConfig, _gaussian, _log_prob, _seen, _unroll,  # noqa: E402
                            actor_arrays, apply, init_network, learning_rate_at, make_chunks, make_train,
                            play_deterministic)
from agents.mlp_policy import MlpPolicyAgent, save_policy  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
OBS = 5  # LightSail-v0's observation size
#: The smoke run below as the code before policies had a memory trained it (JAX 0.9.2, this file's
#: XLA flags): per seed, the actor's first biases' sum of magnitudes and the final log std.
BEFORE_MEMORY = {"b0": [0.3423852325, 0.303506364], "log_std": [[-1.0022090673, -0.9989134669],
                                                                [-1.0009667873, -0.9891780019]]}


def test_two_seeds_train_in_one_vmap_and_the_export_acts_as_the_actor(tmp_path: Path) -> None:
    env, params = sail_env.jax.make("LightSail-v0")
    config = PPOConfig(total_timesteps=2048, num_envs=16, num_steps=32, num_minibatches=4, update_epochs=2)
    out = jax.jit(jax.vmap(make_train(env, params, config)))(jax.random.split(jax.random.key(0), 2))
    assert out["metrics"]["reward"].shape == (2, config.num_updates)
    assert bool(jnp.all(jnp.isfinite(out["metrics"]["reward"])))
    first, second = (jax.tree.map(lambda a: np.asarray(a)[row], out["network"]) for row in (0, 1))
    assert not np.array_equal(first["actor"]["layers"][0]["w"], second["actor"]["layers"][0]["w"])  # the seeds differ
    # history = 1, recurrent = 0 train as before (bit for bit on this machine; the tolerance: other CPUs)
    b0 = np.abs(np.asarray(out["network"]["actor"]["layers"][0]["b"], np.float64)).sum(axis=1)
    np.testing.assert_allclose(b0, BEFORE_MEMORY["b0"], rtol=1e-5)
    np.testing.assert_allclose(out["network"]["log_std"], BEFORE_MEMORY["log_std"], rtol=1e-5)
    save_policy(tmp_path / "policy.npz", actor_arrays(first), {"env_id": "LightSail-v0", "algo": "jax_ppo"})
    agent = MlpPolicyAgent(tmp_path / "policy.npz")  # a file from before memory: no history, no recurrent
    obs = np.random.default_rng(1).normal(size=(50, 5)).astype(np.float32)
    expected = np.clip(np.asarray(apply(first["actor"], jnp.asarray(obs), None, None)[0]), -1, 1)
    np.testing.assert_allclose(agent.act(obs), expected, rtol=1e-5, atol=1e-6)
    with pytest.raises(ValueError, match="observations of size 5"):
        agent.act(np.zeros(25))


#: A smoke run with memory: each environment's rollout outlasts its first episode (200 steps at most).
MEMORY_RUN = PPOConfig(total_timesteps=2 * 4 * 210, num_envs=4, num_steps=210, num_minibatches=2, update_epochs=1)


def _rollout_and_training(config: PPOConfig, env_id: str = "LightSail-v0"):
    """A run's two updates (network, metrics), then a third rollout: the state before it, its
    transitions and the GRUs' states it began with."""
    env, params = sail_env.jax.make(env_id)
    chunks = make_chunks(env, params, config)

    @jax.jit
    def run(key: jax.Array):
        trained, metrics = chunks.run(chunks.init(key), config.num_updates)
        _, transitions, before = chunks.rollout(trained)
        return trained, transitions, before, metrics

    return run(jax.random.key(0))


def _actions(actor: dict, config: PPOConfig, obs: jax.Array, start: jax.Array) -> np.ndarray:
    """The JAX actor's deterministic actions along observations (T, N, D) whose episodes begin where
    ``start`` (T, N) (all at t = 0), as the rollout carries its memory."""
    def step(memory: Memory, inputs):
        mean, hidden = apply(actor, memory.inputs, memory.hidden["actor"], memory.start)
        return memory.next(*inputs, {**memory.hidden, "actor": hidden}), mean

    last, means = jax.lax.scan(step, Memory.first(obs[0], config), (obs[1:], start[1:]))
    final = apply(actor, last.inputs, last.hidden["actor"], last.start)[0]
    means = np.concatenate([means, final[None]])
    return np.tanh(means) if config.tanh_mean else np.clip(means, -1.0, 1.0)


def _check_memory(tmp_path: Path, config: PPOConfig):
    """What every kind of memory must do; returns the run for the kind's own checks."""
    state, rollout, before, metrics = _rollout_and_training(config)
    network = state.network
    assert bool(jnp.all(jnp.isfinite(metrics["reward"])))
    # the rollout: an episode starts where the previous step ended one (the env's autoreset)
    start, done = np.asarray(rollout.start), np.asarray(rollout.done)
    assert np.array_equal(start[1:], done[:-1]) and done[:-1].any(axis=0).all()
    # its observations: the last `history`, shifted along, zeros before an episode's first
    window = config.history * OBS
    seen = np.asarray(rollout.obs)[..., :window].reshape(config.num_steps, config.num_envs, config.history, OBS)
    assert not seen[start][:, :-1].any()
    np.testing.assert_array_equal(seen[1:, :, :-1][~start[1:]], seen[:-1, :, 1:][~start[1:]])
    obs = seen[:, :, -1]
    if config.episode_mean:  # then the mean of the episode's observations so far, the newest included
        mean = np.asarray(rollout.obs)[..., window:]
        checked = 0
        for env in range(config.num_envs):
            began = None  # the step its episode began, once one begins within the rollout
            for t in range(config.num_steps):
                began = t if start[t, env] else began
                if began is not None:
                    np.testing.assert_allclose(mean[t, env], obs[began:t + 1, env].mean(axis=0), rtol=1e-5, atol=1e-6)
                    checked += began < t
        assert checked > 50  # steps after the start of an episode that began within the rollout
    start = start.copy()
    start[0] = True  # played from here below
    # nothing before an episode's start reaches its actions
    actor = jax.tree.map(jnp.asarray, network["actor"])
    actions = _actions(actor, config, obs, start)
    env = int(np.flatnonzero(start[1:].any(axis=0))[0])
    boundary = 1 + int(np.flatnonzero(start[1:, env])[0])
    noisy = obs.copy()
    noisy[:boundary, env] += np.random.default_rng(0).normal(size=(boundary, OBS)).astype(np.float32)
    changed = _actions(actor, config, noisy, start)
    assert not np.array_equal(changed[boundary - 1, env], actions[boundary - 1, env])
    np.testing.assert_array_equal(changed[boundary:], actions[boundary:])
    # the NumPy player: the same actions, its memory reset by evaluate.py's reset(which)
    save_policy(tmp_path / "policy.npz", actor_arrays(network),
                {"env_id": "LightSail-v0", "algo": "jax_ppo", "history": config.history, "recurrent": config.recurrent,
                 "episode_mean": config.episode_mean, "tanh_mean": config.tanh_mean})
    agent = MlpPolicyAgent(tmp_path / "policy.npz")
    played = []
    for t in range(config.num_steps):
        agent.reset(start[t])
        played.append(agent.act(obs[t]))
    np.testing.assert_allclose(np.array(played), actions, rtol=0, atol=1e-5)
    agent.reset()
    np.testing.assert_allclose(agent.act(obs[0, 0]), actions[0, 0], rtol=0, atol=1e-5)  # one observation (D,)
    with pytest.raises(ValueError, match="reset"):
        agent.act(obs[1])
    return state, rollout, before


def test_a_history_policy_sees_the_last_observations_of_its_episode_and_their_mean(tmp_path: Path) -> None:
    # with the actor's mean squashed (the NumPy player must squash it too); the GRU's test: without
    _check_memory(tmp_path, dataclasses.replace(MEMORY_RUN, history=3, episode_mean=True, tanh_mean=True))


def test_a_recurrent_policy_carries_its_gru_through_the_rollout_and_the_update(tmp_path: Path) -> None:
    config = dataclasses.replace(MEMORY_RUN, recurrent=8, history=2, clipped_likelihood=True)
    state, rollout, hidden = _check_memory(tmp_path, config)
    assert np.abs(np.asarray(rollout.action)).max() == 1.0  # the clipped actions the env played, some at a bound
    assert not np.asarray(rollout.start[0]).all()  # the rollout continues episodes: the GRUs' states before it count
    # the update re-runs the GRU over each environment's sequence from the state before it, with the
    # rollout's resets: the log-probabilities of the rollout's actions come back
    network = state.network
    mean = _unroll(network["actor"], hidden["actor"], rollout.obs, rollout.start)
    np.testing.assert_allclose(_log_prob(mean, network["log_std"], rollout.action, clipped=True), rollout.log_prob,
                               atol=1e-4)
    value = _unroll(network["critic"], hidden["critic"], rollout.obs, rollout.start)[..., 0]
    np.testing.assert_allclose(value, rollout.value, atol=1e-5)
    # a GRU's reset: the state before an episode's first input is not read
    actor = network["actor"]
    x = jnp.ones((3, config.history * OBS))
    fresh = apply(actor, x, jnp.zeros((3, 8)), jnp.ones(3, bool))
    stale = apply(actor, x, jnp.full((3, 8), 0.5), jnp.array([True, True, False]))
    np.testing.assert_array_equal(fresh[0][:2], stale[0][:2])
    assert not np.array_equal(fresh[0][2], stale[0][2])


def test_a_privileged_critic_sees_its_episodes_draw_and_the_actor_its_observations(tmp_path: Path) -> None:
    """The bank's factors are what its rows are: each row's axial acceleration is the nominal's over
    its total mass's factor. The critic sees its episode's row beside its memory (the row changes
    only where an episode starts), in the update as in the rollout; the actor, what is exported, sees
    the observations alone; an actor that saw the draw is refused by the NumPy player."""
    env, params = sail_env.jax.make("LightSailRealistic-v0")
    config, plant, factors = env.spec.config, env.spec.plant, np.asarray(params.factors)
    assert factors.shape == (sail_env.jax.env.DRAWS, len(plant.spread_fields))
    assert np.ptp(factors, axis=0).min() > 0.19  # each factor spread over its ±10 %
    mass_factor = (factors[:, 0] * config.sail_mass_kg + factors[:, 1] * config.craft_mass_kg) / config.total_mass_kg
    nominal = plant.params(np.ones((1, plant.n_factors))).acceleration[0]
    np.testing.assert_allclose(np.asarray(params.acceleration) * mass_factor, nominal, rtol=1e-12)

    ppo = dataclasses.replace(MEMORY_RUN, history=2, privileged_critic=True)
    state, rollout, _, metrics = _rollout_and_training(ppo, "LightSailRealistic-v0")
    assert bool(jnp.all(jnp.isfinite(metrics["reward"])))
    network, obs_size = state.network, env.observation_space(params).shape[0]
    assert network["actor"]["layers"][0]["w"].shape[0] == 2 * obs_size
    assert network["critic"]["layers"][0]["w"].shape[0] == 2 * obs_size + plant.n_factors
    seen, start = np.asarray(rollout.factors), np.asarray(rollout.start)
    assert (seen[..., None, :] == factors.astype(np.float32)).all(axis=-1).any(axis=-1).all()  # rows of the bank
    kept = (seen[1:] == seen[:-1]).all(axis=-1)
    assert kept[~start[1:]].all() and start[1:].any() and not kept[start[1:]].any()
    value = _unroll(network["critic"], None, _seen(ppo, "critic", rollout.obs, rollout.factors), rollout.start)[..., 0]
    np.testing.assert_allclose(value, rollout.value, atol=1e-5)
    blind = _unroll(network["critic"], None, _seen(ppo, "critic", rollout.obs, 0 * rollout.factors), rollout.start)
    assert not np.allclose(blind[..., 0], rollout.value, atol=1e-3)  # the value reads the draw

    save_policy(tmp_path / "policy.npz", actor_arrays(network), {"env_id": "LightSailRealistic-v0", "history": 2})
    assert MlpPolicyAgent(tmp_path / "policy.npz").obs_size == obs_size
    oracle = dataclasses.replace(ppo, privileged_actor=True)
    actor = init_network(jax.random.key(0), obs_size, env.num_actions, oracle, plant.n_factors)["actor"]  # (it was 1: broadcast)
    assert 0.0 <= float(play_deterministic(env, params, oracle, actor, jax.random.key(1), 8)[0]) <= 1.0
    save_policy(tmp_path / "oracle.npz", actor_arrays({"actor": actor}),
                {"env_id": "LightSailRealistic-v0", "history": 2, "privileged_actor": True})
    with pytest.raises(ValueError, match="parameter draw"):
        MlpPolicyAgent(tmp_path / "oracle.npz")


def test_a_state_dependent_std_draws_each_action_with_its_states_spread_and_exports_the_mean(tmp_path: Path) -> None:
    """The actor's second half of outputs moves the log std per state: the rollout samples each action
    with its own state's σ and scores it so, the update scores it again the same, and the exported
    actor is the mean alone."""
    env, params = sail_env.jax.make("LightSailRealistic-v0")
    config = dataclasses.replace(MEMORY_RUN, history=2, tanh_mean=True, state_dependent_std=True)
    chunks = make_chunks(env, params, config)
    state = chunks.init(jax.random.key(0))
    network = state.network
    size = network["log_std"].shape[0]
    last = network["actor"]["layers"][-1]
    assert last["w"].shape[1] == 2 * size
    # spread the states' log std over much of its range (at initialisation it varies by ~1e-2)
    rng = np.random.default_rng(0)
    spread = {"w": last["w"].at[:, size:].set(jnp.asarray(rng.normal(0.0, 0.5, (last["w"].shape[0], size)),
                                                          jnp.float32)), "b": last["b"]}
    network = {**network, "actor": {**network["actor"], "layers": [*network["actor"]["layers"][:-1], spread]}}
    state = state._replace(network=network)
    _, rollout, _ = jax.jit(chunks.rollout)(state)
    mean, log_std = _gaussian(_unroll(network["actor"], None, rollout.obs, rollout.start), network["log_std"], config)
    log_std = np.asarray(log_std)
    assert np.ptp(log_std) > 2.0 and LOG_STD_RANGE[0] <= log_std.min() and log_std.max() <= LOG_STD_RANGE[1]
    z = (np.asarray(rollout.action) - np.asarray(mean)) / np.exp(log_std)
    assert abs(z.std() - 1.0) < 0.05 and abs(z.mean()) < 0.05  # 4 envs x 210 steps x 1 action: ±0.025 (1σ)
    np.testing.assert_allclose(_log_prob(mean, jnp.asarray(log_std), rollout.action), rollout.log_prob, atol=1e-4)
    # the update's metrics (its rollout is this one): σ over the rollout and at the episodes' last steps
    metrics = jax.jit(chunks.run, static_argnums=1)(state, 1)[1]
    std, done = np.exp(log_std).mean(axis=-1), np.asarray(rollout.done)
    assert done.any() and not done.all()
    np.testing.assert_allclose(metrics["std"], [std.mean()], rtol=1e-5)
    np.testing.assert_allclose(metrics["std_at_end"], [std[done].mean()], rtol=1e-5)
    assert not np.allclose(_log_prob(mean, network["log_std"], rollout.action), rollout.log_prob, atol=1e-2)
    save_policy(tmp_path / "policy.npz", actor_arrays(network),
                {"env_id": "LightSailRealistic-v0", "history": 2, "tanh_mean": True})
    agent = MlpPolicyAgent(tmp_path / "policy.npz")
    agent.reset()
    first = np.asarray(rollout.obs)[0, 0, -agent.obs_size:]  # an episode's first observation (after zeros)
    np.testing.assert_allclose(agent.act(first), np.asarray(mean)[0, 0], atol=1e-5)


def test_the_clipped_likelihood_is_the_clipped_gaussians() -> None:
    """Inside the box the Gaussian's density, at a bound the mass beyond it (SciPy's normal as the
    reference); the default is the density alone, wherever the action."""
    mean, std = np.array([0.5, -0.2, 1.3]), np.array([0.3, 0.5, 0.2])
    action = np.array([1.0, -1.0, 0.2])
    expected = (stats.norm.logsf(1.0, 0.5, 0.3) + stats.norm.logcdf(-1.0, -0.2, 0.5)
                + stats.norm.logpdf(0.2, 1.3, 0.2))
    args = jnp.asarray(mean), jnp.log(jnp.asarray(std)), jnp.asarray(action)
    np.testing.assert_allclose(_log_prob(*args, clipped=True), expected, rtol=1e-12)
    np.testing.assert_allclose(_log_prob(*args), stats.norm.logpdf(action, mean, std).sum(), rtol=1e-12)


def test_the_deterministic_play_counts_the_actions_beyond_the_box() -> None:
    """An actor that asks for a constant action (zero weights, a bias): every component beyond the box,
    or none; none ever with ``tanh_mean``."""
    env, params = sail_env.jax.make("LightSail-v0")
    config = PPOConfig()
    actor = init_network(jax.random.key(0), OBS, 2, config)["actor"]  # LightSail-v0 has two inputs (1 was broadcast)
    last = {"w": jnp.zeros_like(actor["layers"][-1]["w"]), "b": jnp.zeros_like(actor["layers"][-1]["b"])}
    shares = {}
    for bias in (0.0, 0.9, -1.1, 3.0):
        constant = {**actor, "layers": [*actor["layers"][:-1], {**last, "b": last["b"] + bias}]}
        success, share = play_deterministic(env, params, config, constant, jax.random.key(1), 64)
        assert 0.0 <= float(success) <= 1.0
        shares[bias] = float(share)
    assert shares == {0.0: 0.0, 0.9: 0.0, -1.1: 1.0, 3.0: 1.0}
    squashed = dataclasses.replace(config, tanh_mean=True)
    assert float(play_deterministic(env, params, squashed, constant, jax.random.key(1), 64)[1]) == 0.0


def test_bad_settings_are_refused_naming_them() -> None:
    with pytest.raises(ValueError, match="num_minibatches"):
        PPOConfig(num_envs=3, num_steps=3, num_minibatches=2)
    with pytest.raises(ValueError, match="gamma"):
        PPOConfig(gamma=1.5)
    assert dataclasses.replace(PPOConfig(), total_timesteps=10**6).num_updates == 10**6 // 4096


@pytest.mark.parametrize("argv, message", [
    (["--env", "CartPole-v1"], "JAX backend has"), (["--seeds", "0"], "--seeds"),
    (["-n", "10"], "total_timesteps"), (["--hidden", "64,x"], "--hidden"), (["--hidden", "64,0"], "--hidden"),
    (["--gamma", "1.5"], "gamma"), (["--gae-lambda", "0"], "gae_lambda must be in (0.0, 1.0]"),
    (["--final-learning-rate", "0.1"], "final_learning_rate must be in [0"),
    (["--no-anneal-lr", "--final-learning-rate", "1e-5"], "it needs anneal_lr"),
    (["--ent-coef", "-0.1"], "ent_coef"), (["--history", "0"], "--history"),
    (["--recurrent", "8", "--num-envs", "6", "--num-minibatches", "4"], "num_envs (6) must be a multiple"),
    (["--privileged-critic"], "LightSail-v0 draws no parameters"), (["--resume", "runs/x"], "drop --runs-dir"),
    (["--coast", "fast"], "coast='fast' is for the tasks whose coast follows the flight"),
    (["--coast", "quick"], "--coast: invalid choice"), (["--terminal-reward", "mean"], "--terminal-reward"),
    (["--expected-paths", "4"], "--expected-paths: the paths are for --terminal-reward expected"),
    (["--terminal-reward", "expected", "--expected-paths", "0"], "--expected-paths")])
def test_train_jax_refuses_in_one_line_and_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                          argv: list[str], message: str) -> None:
    import train_jax

    assert train_jax.main([*argv, "--runs-dir", str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "runs").exists()


def test_train_jax_makes_the_env_its_flags_choose() -> None:
    """--coast, --terminal-reward, --expected-paths and --draws reach sail_env.jax.make (the defaults as none)."""
    import train_jax

    assert train_jax.env_options("default", None, "sampled") == ()
    assert train_jax.env_options("fast", None, "expected", 64) == (
        ("coast", "fast"), ("expected_paths", train_jax.EXPECTED_PATHS), ("terminal_reward", "expected"), ("draws", 64))
    env, params = train_jax.task("LightSailRealistic-v0", train_jax.env_options("default", 4, "expected", 8))
    assert (env.expected_paths, env.expected_reward, params.acceleration.shape) == (4, True, (8,))
    assert train_jax.options_of({"env_options": {"expected_paths": 4}}) == (("expected_paths", 4),)
    assert train_jax.options_of({}) == ()


def test_train_jax_anneals_the_learning_rate_to_its_floor_unless_told_not_to() -> None:
    import train_jax

    parse = train_jax.build_parser().parse_args
    assert train_jax.config_of(vars(parse([]))).anneal_lr
    assert not train_jax.config_of(vars(parse(["--no-anneal-lr"]))).anneal_lr
    config = train_jax.config_of(vars(parse(["-n", "40960", "--learning-rate", "1e-3",
                                             "--final-learning-rate", "2e-4"])))
    per_update = config.num_minibatches * config.update_epochs
    assert config.num_updates == 10 and config.final_learning_rate == 2e-4
    steps = np.array([0, per_update - 1, 5 * per_update, 10 * per_update])
    np.testing.assert_allclose(learning_rate_at(config, jnp.asarray(steps)), [1e-3, 1e-3, 6e-4, 2e-4], rtol=1e-6)
    zero = dataclasses.replace(config, final_learning_rate=0.0)  # the default: to 0, as CleanRL's
    np.testing.assert_allclose(learning_rate_at(zero, jnp.asarray(steps)), [1e-3, 1e-3, 5e-4, 0.0], atol=1e-12)


def test_train_jax_resumes_an_interrupted_run_to_the_networks_of_an_uninterrupted_one(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """Interrupted during its second chunk of one update, then resumed: the networks, optimiser and
    everything else the checkpoint holds are those of a run in one chunk of two updates, to the bit."""
    import train_jax

    argv = ["-n", "512", "--num-envs", "8", "--num-steps", "32", "--num-minibatches", "2", "--update-epochs", "1",
            "--history", "2", "--recurrent", "4", "--seeds", "2"]
    assert train_jax.main([*argv, "--checkpoint-every", "2", "--runs-dir", str(tmp_path / "whole")]) == 0
    chunks, run_chunk = [], train_jax.run_chunk

    def interrupted(*args, **kwargs):  # Ctrl-C during the second chunk
        if chunks:
            raise KeyboardInterrupt
        chunks.append(args)
        return run_chunk(*args, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(train_jax, "run_chunk", interrupted)
        assert train_jax.main([*argv, "--checkpoint-every", "1", "--runs-dir", str(tmp_path / "parts")]) == 130
    run = tmp_path / "parts" / "LightSail-v0-jax_ppo-1"  # any seed's folder
    assert f"--resume {tmp_path / 'parts' / 'LightSail-v0-jax_ppo-0'}" in capsys.readouterr().err
    record = json.loads((run / "run.json").read_text())
    assert record["status"] == "running" and record["updates"] == 1 and len(record["success_per_update"]) == 1
    with np.load(run / "policy.npz") as snapshot:  # the policy after the chunk that finished, playable
        assert json.loads(str(snapshot["meta"]))["timesteps"] == record["steps_per_update"]
    assert len(record["curve"]) == 1 and record["curve"][0][0] == record["steps_per_update"]
    assert record["beyond_box"][0][0] == record["steps_per_update"] and 0 <= record["beyond_box"][0][1] <= 1
    steps, std, _ = record["exploration_std"][0]  # the default's σ: e^log_std_init, moved by one update
    assert steps == record["steps_per_update"] and abs(std - np.exp(PPOConfig.log_std_init)) < 0.01
    assert train_jax.main(["--resume", str(run), "--checkpoint-every", "1"]) == 0
    for seed in (0, 1):
        whole, parts = (tmp_path / kind / f"LightSail-v0-jax_ppo-{seed}" for kind in ("whole", "parts"))
        for name in ("policy.npz", *(["checkpoint.npz"] if seed == 0 else [])):
            with np.load(whole / name) as one, np.load(parts / name) as other:
                assert one.files == other.files
                for key in one.files:
                    if key not in ("meta", "progress"):
                        np.testing.assert_array_equal(one[key], other[key], err_msg=f"{name}: {key}")
        one, other = (json.loads((folder / "run.json").read_text()) for folder in (whole, parts))
        assert other["status"] == "finished" and other["resumed"][0]["at_update"] == 1
        for key in ("success_per_update", "final_success_jax_1000", "updates", "config"):
            assert one[key] == other[key], key
        assert one["curve"][-1] == other["curve"][-1]  # after each run's chunks: 2 updates, and 1 + 1
        # the best policy: the curve's first highest point, and the actor saved after that chunk
        assert other["best"] == max(other["curve"], key=lambda point: point[1])
        with np.load(parts / "best_policy.npz") as best:
            assert json.loads(str(best["meta"]))["timesteps"] == other["best"][0]
    capsys.readouterr()
    assert train_jax.main(["--resume", str(run)]) == 2
    assert "has finished" in capsys.readouterr().err
    assert train_jax.main(["--resume", str(run), "--seeds", "3"]) == 2
    assert "drop --seeds" in capsys.readouterr().err
    assert train_jax.main(["--resume", str(run), "--first-seed", "0"]) == 2  # a flag at its default is given too
    assert "drop --first-seed" in capsys.readouterr().err
    assert train_jax.main(["--resume", str(tmp_path)]) == 2
    assert "not a run folder" in capsys.readouterr().err
    emptied = tmp_path / "emptied" / "LightSail-v0-jax_ppo-0"  # the first seed's folder holds the checkpoint
    shutil.copytree(tmp_path / "parts" / emptied.name, emptied)
    record = json.loads((emptied / "run.json").read_text())
    (emptied / "run.json").write_text(json.dumps({**record, "status": "running"}))
    (emptied / "checkpoint.npz").write_bytes(b"")
    assert train_jax.main(["--resume", str(emptied)]) == 2  # an EOFError's traceback before
    assert "empty, cut short or not an .npz file" in capsys.readouterr().err


def test_evaluate_reports_a_jax_policy_beside_the_baselines(tmp_path: Path) -> None:
    """``evaluate.py --agent …/policy.npz`` plays the exported actor on the Gym env (no JAX there), a
    memoryless one and one with both kinds of memory."""
    runs = {}
    for name, config in (("LightSail-v0-jax_ppo-0", PPOConfig()), ("memory", PPOConfig(history=2, recurrent=4))):
        network = jax.tree.map(np.asarray, init_network(jax.random.key(0), 5, 2, config))
        runs[name] = tmp_path / "runs" / name
        runs[name].mkdir(parents=True)
        save_policy(runs[name] / "policy.npz", actor_arrays(network),
                    {"env_id": "LightSail-v0", "algo": "jax_ppo", "history": config.history, "recurrent": config.recurrent,
                 "episode_mean": config.episode_mean})
    run = runs["LightSail-v0-jax_ppo-0"]
    done = subprocess.run([sys.executable, "evaluate.py", "--agent", "passive", "--agent", str(run / "policy.npz"),
                           "--agent", str(runs["memory"] / "policy.npz"), "--episodes", "4", "--out",
                           str(tmp_path / "report")], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    report = json.dumps(json.loads((tmp_path / "report" / "report.json").read_text()))
    assert '"jax_ppo:LightSail-v0-jax_ppo-0/policy"' in report and '"jax_ppo:memory/policy"' in report
    refused = subprocess.run([sys.executable, "evaluate.py", "--env", "LightSailRealistic-v0", "--agent",
                              str(run / "policy.npz"), "--episodes", "1", "--out", str(tmp_path / "other")], cwd=ROOT,
                             capture_output=True, text=True, timeout=300)
    assert refused.returncode == 2 and "observations of size 5" in refused.stderr and refused.stderr.count("\n") == 1
