"""One task, two backends: the JAX env against the Numba core, fed the same draws.

JAX's random keys cannot reproduce NumPy's streams, so both backends are given the same draws: the
launch states, each episode's parameter draw (the JAX params' bank is made of the Numba episodes'
draws), cut-off and pre-control noise (the JAX env's ``reset_from``), each step's normals (its
``advance``) and the actions, over N = 256 environments and 1,000 steps with autoreset, every id of
``JAX_TASKS``. Observations must agree to the bit (under the XLA flag of ``conftest.py``), the state within
1e-12 (relative, or of its scales), the rewards of the window's steps within 1e-12 (relative, or
1e-15 absolute near zero), and the terminal pointing within 1e-9 relative; after a noisy coast
within 1e-8 relative or 1e-16 rad (see :func:`_assert_pointing`).
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("gymnax")

import jax.numpy as jnp  # noqa: E402

import sail_env.jax  # noqa: E402
from sail_env.core.episode import EpisodeCore  # noqa: E402
from sail_env.core.state import Slot  # noqa: E402
from sail_env.jax.env import EpisodeStart, StepNoise, bank_of  # noqa: E402
from sail_env.tasks import JAX_TASKS  # noqa: E402

ENVS, STEPS = 256, 1000
#: Along the flight (the realistic 3D tasks) each backend coasts the pre-control flight and the coast to
#: cut-off through its own exponential of every 5 s piece's generator (JAX's and SciPy's, ~1e-11 of the
#: moments apart): the episodes then agree to these tolerances (relative, of the state's scales, in
#: observation units), not to the bit. Measured on v1 (32 environments × 400 steps): state 1.6e-7, rewards
#: 1.4e-8, pointing 7.2e-8; the Numba core's own v1 episodes differ by 4e-8 between two OpenBLAS kernels
#: (docs/physics.md §3).
ALONG_TOLERANCE = 1e-6
#: The realistic 3D tasks' coast costs ~50 ms an episode on each backend: fewer, still every feature (the
#: uncertain tasks' versions differ only in how a draw is made and how its sail widens: fewer still).
SIZES = {"LightSail3DRealistic-v0": (48, 500), "LightSail3DRealistic-v1": (48, 500),
         "LightSailUncertain-v1": (16, 500), "LightSailUncertain-v2": (48, 500)}
EXACT = "--xla_cpu_max_isa=AVX" in os.environ.get("XLA_FLAGS", "")


def _launches(spec, rng: np.random.Generator, count: int) -> np.ndarray:
    """Launch states: most inside the task's box, one in eight near the start limits (some of
    those leave the beam within the window, so divergence and its early reset are exercised)."""
    box = spec.start_half_widths * rng.uniform(-1, 1, (count, spec.plant.n_states))
    wide = spec.start_limits * rng.uniform(-0.98, 0.98, (count, spec.plant.n_states))
    return np.where((rng.random(count) < 0.125)[:, None], wide, box)


class SameDraws:
    """Episode ``e`` of the Numba core plays with generator seed ``e``; this replays that generator's
    draws in the core's order (the parameter factors and the cut-off's uniforms, the pre-control
    coast's normals, the window's normals, the impacts' counts, the coast's normals) for the JAX env,
    whose bank is made of every episode's parameter draw (row ``e``). A generator's normals come in
    sequence, so the coast's are drawn for the most pieces any coast takes: the core draws the first
    ones of them."""

    def __init__(self, spec, env, episodes: int) -> None:
        self.spec, self.env, plant = spec, env, spec.plant
        self.layout = EpisodeCore(spec, 1).state.layout
        uniforms = plant.n_draws + (1 if spec.randomisation.cutoff_jitter_s else 0)
        n, block = plant.n_states, int(self.layout[Slot.NORMALS])
        factors = []
        for e in range(episodes):
            factors.append(plant.factors(np.random.default_rng(e).random((1, plant.n_draws)))[0])
        self.params = bank_of(spec, np.array(factors))
        p = plant.params(np.array(factors))
        lag0 = np.asarray(self.params.delay[:, 0])
        pre_pieces = plant.coast_pieces(p, spec.config.control_start_s - lag0 * spec.dt) * np.ones(episodes, int)
        rates = plant.impact_rate_and_std(p, np.full(episodes, spec.window_middle_s))[0] if env.impulse_rows else None
        steps = int(self.layout[Slot.NOISE_STEPS])
        self.draws = []
        for e in range(episodes):
            rng = np.random.default_rng(e)
            u = rng.random(uniforms)
            pre = np.zeros((self.params.pre_pieces, n))
            if plant.noisy:
                pre[:pre_pieces[e]] = rng.standard_normal(pre_pieces[e] * n).reshape(-1, n)
            normals = rng.standard_normal(block)
            counts = rng.poisson(rates[e] * spec.dt, steps) if rates is not None else np.zeros(steps)
            coast = rng.standard_normal((self.params.coast_pieces, n)) if plant.noisy else np.zeros((1, n))
            self.draws.append((u, pre, normals, counts, coast))

    def normals(self, episode: int) -> np.ndarray:
        return self.draws[episode][2]

    def _column(self, normals: np.ndarray, column: int) -> np.ndarray:
        """The beam jitter's, the push's and the impacts' normals of noise step ``column`` (J + 1 + r,)."""
        jittered, impacts = len(self.env.jitter_inputs), len(self.env.impulse_rows)
        out = np.zeros(jittered + 1 + impacts)
        first, push = int(self.layout[Slot.JITTER_NORMALS]), int(self.layout[Slot.PUSH_NORMALS])
        if jittered and first + (column + 1) * jittered <= push:
            out[:jittered] = normals[first + column * jittered:first + (column + 1) * jittered]
        if self.env.pushed and push + column < int(self.layout[Slot.SENSOR_NORMALS]):
            out[jittered] = normals[push + column]
        kicks = int(self.layout[Slot.IMPACT_NORMALS]) + column * impacts
        if impacts and kicks + impacts <= len(normals):
            out[jittered + 1:] = normals[kicks:kicks + impacts]
        return out

    def _sensor(self, normals: np.ndarray, step: int) -> np.ndarray:
        n, first = self.spec.plant.n_states, int(self.layout[Slot.SENSOR_NORMALS])
        return normals[first + step * n:first + (step + 1) * n] if self.env.sensed else np.zeros(n)

    def start(self, episodes: np.ndarray, launch: np.ndarray) -> EpisodeStart:
        spec, rows = self.spec, []
        for e, x in zip(episodes, launch):
            u, pre, normals, counts, _ = self.draws[e]
            jitter = spec.randomisation.cutoff_jitter_s
            cutoff = spec.config.beam_cutoff_s + ((-jitter + (jitter - -jitter) * u[-1]) if jitter else 0.0)
            pre_steps = np.array([self._column(normals, s) for s in range(self.env.max_delay)])
            rows.append((x, e, cutoff, pre, pre_steps, counts[:self.env.max_delay].astype(float),
                         self._sensor(normals, 0)))
        return EpisodeStart(*(jnp.asarray(np.array(column)) for column in zip(*rows)))

    def noise(self, episodes: np.ndarray, steps: np.ndarray, lags: np.ndarray) -> StepNoise:
        rows, jittered = [], len(self.env.jitter_inputs)
        for e, now, lag in zip(episodes, steps, lags):
            _, _, normals, counts, coast = self.draws[e]
            this = self._column(normals, now + lag)
            flight = [self.spec.n_steps + k + lag for k in range(self.env.max_delay + 2)]
            rows.append((this[:jittered], this[jittered], this[jittered + 1:], float(counts[now + lag]),
                         self._sensor(normals, now + 1), np.array([self._column(normals, c) for c in flight]),
                         np.array([counts[c] if c < len(counts) else 0 for c in flight], float), coast))
        return StepNoise(*(jnp.asarray(np.array(column)) for column in zip(*rows)))


#: ``LightSailUncertain-v0`` is v1 but for the factors the NumPy plant draws, which both backends take from it.
@pytest.mark.parametrize("env_id", [task for task in JAX_TASKS if task != "LightSailUncertain-v0"])
def test_the_same_draws_play_the_same_episodes(env_id: str) -> None:
    env, _ = sail_env.jax.make(env_id, draws=1)
    spec = env.spec
    envs, steps = SIZES.get(env_id, (ENVS, STEPS))
    draws = SameDraws(spec, env, episodes=envs * 8)
    params = draws.params
    core = EpisodeCore(spec, envs)
    reset = jax.jit(jax.vmap(env.reset_from, in_axes=(0, None)))
    advance = jax.jit(env.advance_batch)
    select = jax.jit(lambda done, new, old: jax.tree.map(
        lambda a, b: jnp.where(done.reshape(done.shape + (1,) * (a.ndim - 1)), a, b), new, old))
    rng = np.random.default_rng(0)
    episode, following = np.arange(envs), envs
    launch = _launches(spec, rng, envs)
    core.reset(episode, [np.random.default_rng(e) for e in episode], launch)
    assert all(np.array_equal(core.state.normals[i], draws.normals(e)) for i, e in enumerate(episode))
    obs, state = reset(draws.start(episode, launch), params)
    tolerance = ALONG_TOLERANCE if env.along is not None else 0.0
    _assert_observations(np.asarray(obs), core.observe(), tolerance)
    scored = diverged = 0
    for _ in range(steps):
        lags = core.state.lag0 if spec.light_delay else np.zeros(envs, np.int64)
        noise = draws.noise(episode, core.state.step.copy(), lags.copy())
        action = rng.uniform(-1.2, 1.2, (envs, spec.plant.n_inputs))  # beyond ±1: the clip too
        result = core.step(action)
        obs, state, reward, terminated, info = advance(state, jnp.asarray(action), noise, params)
        _assert_observations(np.asarray(obs), result.observation, tolerance)
        np.testing.assert_allclose(np.asarray(state.x) / spec.state_scale, core.state.x / spec.state_scale,
                                   rtol=tolerance or 1e-12, atol=tolerance or 1e-12)
        np.testing.assert_array_equal(np.asarray(terminated), result.terminated.astype(bool))
        running = ~result.terminated.astype(bool)
        # A step's reward is log10 of the envelope over the tolerance, over the window: near zero, 1e-15 absolute.
        np.testing.assert_allclose(np.asarray(reward)[running], result.reward[running], rtol=tolerance or 1e-12,
                                   atol=1e-15)
        ended = np.flatnonzero(result.terminated)
        if len(ended):
            np.testing.assert_array_equal(np.asarray(info["diverged"])[ended], result.diverged[ended].astype(bool))
            pointing = np.asarray(info["terminal_pointing_rad"])[ended]
            _assert_pointing(env, pointing, result.terminal_pointing_rad[ended],
                             np.asarray(reward)[ended], result.reward[ended], tolerance)
            np.testing.assert_array_equal(np.asarray(info["is_success"])[ended], result.success[ended])
            scored += int(np.sum(~result.diverged[ended].astype(bool)))
            diverged += int(np.sum(result.diverged[ended]))
            episode[ended] = np.arange(following, following + len(ended))
            following += len(ended)
            launch[ended] = _launches(spec, rng, len(ended))
            core.reset(ended, [np.random.default_rng(e) for e in episode[ended]], launch[ended])
            new_obs, new_state = reset(draws.start(episode, launch), params)
            done = np.zeros(envs, dtype=bool)
            done[ended] = True
            state = select(jnp.asarray(done), new_state, state)
            _assert_observations(np.asarray(select(jnp.asarray(done), new_obs, obs))[ended], core.observe(ended),
                                 tolerance)
    assert scored > envs and diverged > 0, (scored, diverged)


def _assert_observations(jax_obs: np.ndarray, numba_obs: np.ndarray, tolerance: float = 0.0) -> None:
    """To the bit under the exactness flag, else 1e-6; ``tolerance`` along the flight (observation units)."""
    if tolerance:
        np.testing.assert_allclose(jax_obs, numba_obs, rtol=tolerance, atol=tolerance)
    elif EXACT:
        np.testing.assert_array_equal(jax_obs.view(np.uint32), numba_obs.view(np.uint32))
    else:
        np.testing.assert_allclose(jax_obs, numba_obs, rtol=1e-6, atol=0)


def _assert_pointing(env, jax_pointing: np.ndarray, numba_pointing: np.ndarray, jax_reward: np.ndarray,
                     numba_reward: np.ndarray, tolerance: float = 0.0) -> None:
    """Terminal pointing within 1e-9 relative. After a noisy coast, within 1e-8 relative or 1e-16 rad
    (1e-8 of the 10 nrad success threshold) instead: both backends draw the state at cut-off from
    second moments given by a matrix exponential of norm ~5e5 (65,000 rad of phase), SciPy's and
    JAX's, each within ~1e-11 of the moments' size (measured against 40-digit mpmath: 1.4e-11 and
    7e-12), so a pointing far below the coast noise's 3 nrad agrees only to that absolute size
    (median 3e-11 relative; here at most 0.39 of this tolerance). The terminal reward then differs by
    what the pointing explains (its log10). Along the flight, ``tolerance`` (:data:`ALONG_TOLERANCE`)."""
    np.testing.assert_array_equal(np.isfinite(jax_pointing), np.isfinite(numba_pointing))
    finite = np.isfinite(numba_pointing)
    rtol, atol = (tolerance, 0.0) if tolerance else (1e-8, 1e-16) if env.noisy else (1e-9, 0.0)
    np.testing.assert_allclose(jax_pointing[finite], numba_pointing[finite], rtol=rtol, atol=atol)
    explained = np.abs(jax_pointing[finite] - numba_pointing[finite]) / (numba_pointing[finite] * math.log(10))
    window = tolerance * np.abs(numba_reward[finite])  # along the flight the last step's envelope differs too
    assert np.all(np.abs(jax_reward[finite] - numba_reward[finite]) <= 1.01 * explained + window + 1e-12)
    np.testing.assert_array_equal(jax_reward[~finite], numba_reward[~finite])


def test_float32_keeps_the_scores_to_its_rounding() -> None:
    """The float32 option against float64 on the same launches and actions (1,024 episodes): the
    terminal pointing to 1e-4 in the median (the coast's ~4·10⁴ rad of phase costs float32 its
    digits; at worst ~1 %), success decided alike in all but a handful of episodes."""
    envs = 1024
    launch = _launches(sail_env.jax.make("LightSail-v0")[0].spec, np.random.default_rng(3), envs)
    actions = np.random.default_rng(4).uniform(-0.3, 0.3, (200, envs, 2))
    scores = []
    for dtype in (jnp.float64, jnp.float32):
        env, params = sail_env.jax.make("LightSail-v0", dtype=dtype)
        starts = jax.vmap(env.draw_start, in_axes=(0, None, 0))(jax.random.split(jax.random.key(0), envs), params,
                                                                 jnp.asarray(launch, dtype))
        _, state = jax.vmap(env.reset_from, in_axes=(0, None))(starts, params)

        def one(state, action):
            _, state, reward, _, info = jax.vmap(env.step_env, in_axes=(None, 0, 0, None))(
                jax.random.key(0), state, action, params)
            return state, (reward, info["terminal_pointing_rad"], info["is_success"])

        reward, pointing, success = jax.jit(lambda s: jax.lax.scan(one, s, jnp.asarray(actions, dtype)))(state)[1]
        assert reward.dtype == dtype
        scores.append((np.asarray(reward, np.float64), np.asarray(pointing[-1], np.float64), np.asarray(success[-1])))
    (reward64, pointing64, success64), (reward32, pointing32, success32) = scores
    scored = np.isfinite(pointing64)  # the launches near the limits diverge (inf) in both
    np.testing.assert_array_equal(np.isfinite(pointing32), scored)
    error = np.abs(pointing32[scored] - pointing64[scored]) / pointing64[scored]
    assert np.median(error) < 1e-4 and error.max() < 0.05
    assert np.abs(reward32 - reward64).max() < 1e-2
    assert 0.1 < success64.mean() < 0.9 and np.sum(success32 != success64) <= envs // 100


def test_both_backends_coast_exponentials_hold_the_moments_to_their_stated_accuracy() -> None:
    """The noisy coast's tolerance above rests on this: on a realistic coast's balanced moment
    generator (1-norm ~5e5) SciPy's and JAX's matrix exponentials are each within 5e-11 of a 40-digit
    mpmath one (of its largest entry; docs/physics.md §3 gives 1.4e-11 and 7e-12), and the draws they
    lead to are within 1e-16 rad of pointing of each other."""
    import mpmath
    import scipy.linalg

    from sail_env.physics.noise import balancing, held_input_maps

    env, params = sail_env.jax.make("LightSailRealistic-v0", draws=1)
    plant, n, m = env.spec.plant, env.n_states, env.n_inputs
    command = np.array([0.6, -0.3]) * env.spec.action_scale
    pick, lift0, lift1, lift2 = held_input_maps(n, m)
    lift = lift0 + np.tensordot(command, lift1, 1) + np.tensordot(np.outer(command, command), lift2, 2)
    generator = np.asarray(params.coast_generator[0]) @ lift
    into, back = balancing(plant.start_limits())
    balanced = generator * (588.7 * into)
    assert 2e5 < np.abs(balanced).sum(axis=0).max() < 1e6
    mpmath.mp.dps = 40
    exact = np.array(mpmath.expm(mpmath.matrix(balanced.tolist())).tolist(), dtype=float)
    exponentials = (scipy.linalg.expm(balanced), np.asarray(jax.scipy.linalg.expm(jnp.asarray(balanced),
                                                                                    max_squarings=20)))
    for computed in exponentials:
        assert np.abs(computed - exact).max() < 5e-11 * np.abs(exact).max()
    x = jnp.asarray([1e-3, 2e-2, 1e-5, 1e-4])
    normals = jnp.asarray(np.random.default_rng(0).standard_normal(n))
    draws = [np.asarray(env._sample(jnp.asarray(e * back) @ env._moments(x), normals)) for e in exponentials]
    speed = float(params.speed_at_cutoff[0])
    assert abs(abs(draws[0][1]) - abs(draws[1][1])) / speed < 1e-16
