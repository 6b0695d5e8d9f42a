"""The fast coast (``coast="fast"``, :mod:`sail_env.jax.fast_coast`) against the default coast, and the
score's paths (``expected_paths``, ``terminal_reward="expected"``).

The fast coast draws the state at each piece's end from exact moments, as the default coast does, so the
moments at cut-off are a product of linear maps on the moments for either schedule: the default's even
pieces, the fast coast's draw-fixed whole pieces and a remainder. Both hold each piece's model at its middle;
they differ by that rule's error only, which a schedule of 1 s pieces bounds."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import sail_env.jax as sail_jax
from sail_env.jax.fast_coast import lifted_moments
from sail_env.physics.noise import held_input_maps, mean_and_covariance, second_moment

TASKS = ("LightSail3DRealistic-v1", "LightSailUncertain-v2")


@pytest.fixture(scope="module", params=TASKS)
def fast(request):
    return sail_jax.make(request.param, draws=4, coast="fast")


def moments_at_cutoff(env, params, d, x, u, cutoff, schedule):
    """The exact second moments at ``cutoff`` from ``x`` at the draw's coast start with ``u`` held, drawn at the
    end of each piece of ``schedule``: "maps" (the fast coast's), "grid" (the fast coast's pieces, each built
    as the default coast builds its own), or a length [s] (even pieces of at most that: 5 s is the default's)."""
    coast, along, fast = env.along, params.along, params.fast
    start, length = float(fast.start[d]), float(fast.piece[d])
    m = np.asarray(second_moment(jnp.asarray(x), jnp.zeros((len(x), len(x))), xp=jnp))
    _, lift0, lift1, lift2 = held_input_maps(env.n_states, env.n_inputs)
    lift = lift0 + np.tensordot(u, lift1, 1) + np.tensordot(np.outer(u, u), lift2, 2)
    whole = int(np.floor((cutoff - start) / length))
    if schedule == "maps":
        for j in range(whole):
            m = np.asarray(fast.maps[d, j]) @ (lift @ m)
        bounds = [start + whole * length, cutoff]
    elif schedule == "grid":
        bounds = [*(start + length * np.arange(whole + 1)), cutoff]
    else:
        bounds = np.linspace(start, cutoff, int(np.ceil((cutoff - start) / schedule)) + 1)
    span = jax.jit(lambda lo, hi: coast.span_propagator(along, d, lo, hi, lambda t: coast.generator(along, d, jnp.asarray(u), t),
                                                        params.into_units, params.from_units))
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        m = np.asarray(span(jnp.asarray(lo), jnp.asarray(hi))) @ m
    return mean_and_covariance(m)


@pytest.mark.slow
def test_the_fast_coast_moves_the_moments_as_the_default_coast(fast):
    """The maps are the lifted exponentials (to round-off), and the fast coast's moments at cut-off are as close to
    those of 1 s pieces as the default coast's (5 s pieces): the midpoint rule's error, under 5 % of the state's
    spread in the mean and the covariance, and the fast coast's at most twice the default's (or 1 %). Against 0.5 s
    pieces, over 4 draws of each task: the fast coast 0.3–1.5 % (mean) and 0.4–1.2 % (covariance), the default
    0.5–1.4 % and 0.4–2.3 %."""
    env, params = fast
    rng = np.random.default_rng(0)
    d = 1
    x = rng.uniform(-1, 1, env.n_states) * env.spec.plant.start_limits() * 0.1
    u = rng.uniform(-1, 1, env.n_inputs) * np.asarray(env.spec.action_scale)
    cutoff = 600.0 + rng.uniform(-5, 5)
    maps, grid, default, fine = (moments_at_cutoff(env, params, d, x, u, cutoff, schedule)
                                 for schedule in ("maps", "grid", 5.0, 1.0))
    spread = np.sqrt(np.diag(fine[1]))
    scale = np.outer(spread, spread)

    def error(moments):
        mean, cov = moments
        return max(np.abs(mean - fine[0]) / spread), np.max(np.abs(cov - fine[1]) / scale)

    np.testing.assert_allclose(maps[0] / spread, grid[0] / spread, rtol=0, atol=1e-9)
    np.testing.assert_allclose(maps[1] / scale, grid[1] / scale, rtol=0, atol=1e-9)
    for ours, theirs in zip(error(maps), error(default)):
        assert ours < 0.05 and theirs < 0.05
        assert ours <= max(2 * theirs, 0.01)
    assert np.abs(maps[0] - default[0]).max() > 0  # another schedule: not the default's numbers


def test_the_lifted_moments_are_those_of_the_known_state_and_command():
    x, u = jnp.array([1.0, -2.0]), jnp.array([0.5])
    expected = second_moment(jnp.array([1.0, -2.0, 0.5]), jnp.zeros((3, 3)), xp=jnp)
    np.testing.assert_array_equal(lifted_moments(x, u), expected)


def test_bad_coast_options_are_refused_by_name():
    with pytest.raises(ValueError, match="coast must be one of default, fast"):
        sail_jax.make("LightSail3DRealistic-v1", coast="quick")
    with pytest.raises(ValueError, match="coast='fast' is for the tasks whose coast follows the flight"):
        sail_jax.make("LightSailRealistic-v0", coast="fast")
    for paths in (-1, 1.5, True, "4", 10 ** 6):
        with pytest.raises(ValueError, match="expected_paths must be an int"):
            sail_jax.make("LightSail-v0", expected_paths=paths)
    with pytest.raises(ValueError, match="terminal_reward must be one of sampled, expected"):
        sail_jax.make("LightSail-v0", terminal_reward="mean")
    with pytest.raises(ValueError, match="give expected_paths >= 1"):
        sail_jax.make("LightSail-v0", terminal_reward="expected")


def window_ends(env, params, episodes: int, seed: int = 0):
    """States one step before the window's end (passive: zero actions), their last step's normals, and the
    zero action."""
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(jax.random.key(seed), episodes), params)
    action = jnp.zeros((episodes, env.n_inputs))
    step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
    for t in range(params.max_steps_in_episode - 1):
        obs, state, *_ = step(jax.random.split(jax.random.key(1000 + t), episodes), state, action, params)
    noise = jax.vmap(env._step_noise, in_axes=(0, None, 0))(jax.random.split(jax.random.key(7), episodes), params,
                                                             state.draw)
    return state, noise, action


def expected_at(env, params, state, noise, action, key):
    """The last step from fixed window ends, its end's draws (the coast and the score's paths) from ``key``."""
    keys = jax.random.split(key, state.draw.shape[0])
    noise = jax.vmap(env._with_end_noise, in_axes=(0, 0, None, 0))(noise, keys, params, state.draw)
    _, _, reward, done, info = jax.vmap(env.advance, in_axes=(0, 0, 0, None))(state, action, noise, params)
    assert bool(done.all())
    return np.asarray(info["expected_success"]), np.asarray(info["is_success"]), np.asarray(reward)


@pytest.mark.parametrize("paths", [4, 16])
def test_the_expected_success_varies_as_one_over_the_paths(paths):
    """At fixed window ends the expected success over K paths is a mean of K draws of the success: its variance
    over the end's keys is p (1 − p) / K, p its mean (within the variance's sampling error)."""
    env, params = sail_jax.make("LightSailRealistic-v0", draws=16, expected_paths=paths)
    state, noise, action = window_ends(env, params, 64)
    estimates = np.stack([expected_at(env, params, state, noise, action, jax.random.key(r))[0] for r in range(40)])
    p = estimates.mean(axis=0)
    variable = (p > 0.1) & (p < 0.9)  # window ends whose outcome is in doubt
    assert variable.sum() >= 5
    ratio = estimates.var(axis=0, ddof=1)[variable].sum() / (p * (1 - p) / paths)[variable].sum()
    assert 0.75 < ratio < 1.3  # 40 keys: the variance's sampling error is ~ 1/√20 of it per end, averaged over them


def test_the_expected_success_and_reward_keep_the_sampled_means_and_the_episodes():
    """The tower rule: over fresh window ends the expected success's mean is the sampled success's, and the
    expected terminal reward's mean the sampled one's (within 4 standard errors); and the score's paths draw
    from a key of their own: the episodes, rewards and pointings without them are the same to the bit."""
    env, params = sail_jax.make("LightSailRealistic-v0", draws=16, expected_paths=8)
    plain_env, plain_params = sail_jax.make("LightSailRealistic-v0", draws=16)
    expecting_env, expecting_params = sail_jax.make("LightSailRealistic-v0", draws=16, expected_paths=8,
                                                    terminal_reward="expected")
    state, noise, action = window_ends(env, params, 2000)
    expected, sampled, reward = expected_at(env, params, state, noise, action, jax.random.key(3))
    _, plain_sampled, plain_reward = expected_at(plain_env, plain_params, state, noise, action, jax.random.key(3))
    _, _, expected_reward = expected_at(expecting_env, expecting_params, state, noise, action, jax.random.key(3))
    np.testing.assert_array_equal(sampled, plain_sampled)
    np.testing.assert_array_equal(reward, plain_reward)
    error = np.sqrt(sampled.var() / len(sampled))
    assert abs(expected.mean() - sampled.mean()) < 4 * error
    assert abs(expected_reward.mean() - reward.mean()) < 4 * np.sqrt(reward.var() / len(reward))
    assert expected.var() < sampled.var() and expected_reward.var() < reward.var()
    assert np.isnan(np.asarray(plain_env.reset(jax.random.key(0), plain_params)[1].expected_success))
