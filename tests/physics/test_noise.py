import numpy as np
import pytest
import scipy.integrate
import scipy.linalg

from sail_env.physics import DEEP_DISH, SEED, PlanarModel, WhiteNoise, propagate_moments
from sail_env.physics.planar.model import push_sensitivity


def test_noise_free_moments_are_the_exact_propagation():
    model = PlanarModel(DEEP_DISH)
    mean = np.array([1e-3, 0.1, 1e-4, 0.0])
    beam = np.array([1e-3, 2e-4])
    out_mean, out_cov = propagate_moments(model, mean, np.zeros((4, 4)), beam, 3.7, WhiteNoise())
    phi, gamma = model.discretize(3.7)
    np.testing.assert_allclose(out_mean, phi @ mean + gamma @ beam, rtol=1e-12)
    np.testing.assert_array_equal(out_cov, 0)


@pytest.mark.parametrize("noise", [WhiteNoise(), WhiteNoise(beam_jitter_psd_m2s=1e-10, push_psd_s=1e-4)])
def test_zero_duration_keeps_the_moments(noise):
    mean, cov = np.array([1e-3, 0.1, 1e-4, 0.0]), np.diag([1e-6, 1e-4, 1e-8, 1e-6])
    out_mean, out_cov = propagate_moments(PlanarModel(DEEP_DISH), mean, cov, np.array([1e-3, 2e-4]), 0.0, noise)
    np.testing.assert_allclose(out_mean, mean, rtol=1e-12)
    np.testing.assert_allclose(out_cov, cov, rtol=1e-9, atol=1e-20)


def test_additive_jitter_covariance_matches_the_integral():
    """Van Loan's result, checked against ∫ Φ(s) S b bᵀ Φ(s)ᵀ ds by adaptive quadrature."""
    model = PlanarModel(SEED)
    noise = WhiteNoise(beam_jitter_psd_m2s=2e-10)
    duration = 0.3
    _, cov = propagate_moments(model, np.zeros(4), np.zeros((4, 4)), np.zeros(2), duration, noise)
    b = model.B[:, 0]

    def integrand(s):
        phi, _ = model.discretize(s)
        return (phi @ np.outer(b, b) @ phi.T).ravel() * noise.beam_jitter_psd_m2s

    reference, _ = scipy.integrate.quad_vec(integrand, 0.0, duration, epsabs=0, epsrel=1e-10)
    np.testing.assert_allclose(cov, reference.reshape(4, 4), rtol=1e-6, atol=1e-12 * np.abs(reference).max())


def test_push_noise_moments_match_monte_carlo():
    """Multiplicative push noise against a Heun (Stratonovich) Monte Carlo of many paths."""
    model = PlanarModel(DEEP_DISH)
    noise = WhiteNoise(beam_jitter_psd_m2s=1e-11, push_psd_s=2e-4)
    mean0 = np.array([1e-2, 0.0, 1e-3, 0.0])
    beam = np.array([1e-3, 0.0])
    duration, steps, paths = 0.1, 2000, 4000
    dt = duration / steps
    a_push, b_push = model.push_sensitivity
    rng = np.random.default_rng(0)
    x = np.tile(mean0, (paths, 1))
    for _ in range(steps):
        dw_f = rng.standard_normal((paths, 1)) * np.sqrt(noise.push_psd_s * dt)
        dw_d = rng.standard_normal((paths, 1)) * np.sqrt(noise.beam_jitter_psd_m2s * dt)

        def increment(state):
            drift = state @ model.A.T + model.B @ beam
            mult = state @ a_push.T + b_push @ beam
            return drift * dt + mult * dw_f + model.B[:, 0] * dw_d

        predictor = x + increment(x)
        x = x + 0.5 * (increment(x) + increment(predictor))
    mean, cov = propagate_moments(model, mean0, np.zeros((4, 4)), beam, duration, noise)
    mc_mean, mc_cov = x.mean(axis=0), np.cov(x.T)
    # Per component, four standard errors: of a mean σ/√n, of a covariance √((σ_i² σ_j² + c_ij²)/n).
    var = np.diag(cov)
    assert np.all(np.abs(mc_mean - mean) < 4 * np.sqrt(var / paths))
    cov_error = np.sqrt((np.outer(var, var) + cov**2) / paths)
    assert np.all(np.abs(mc_cov - cov) < 4 * cov_error)
    assert np.all(var > 0) and np.all(np.abs(mc_mean - mean0) > 4 * np.sqrt(var / paths))  # all components move


def test_stratonovich_correction_matches_geometric_brownian_motion():
    """A push-scaled force on the velocity itself, ``dV = λ V (dt + dW_F)`` read as Stratonovich, is
    geometric Brownian motion: ``E[V] = V0 exp((λ + ½ S λ²) t)``, ``E[V²] = V0² exp(2 (λ + S λ²) t)``.

    The planar model never shows the ½ S_F A_F² correction: its push scales forces that depend on
    positions only, so ``A_F² = 0`` and ``A_F B_F = 0`` (asserted last). This system makes it the
    whole difference between the Stratonovich and the Itô mean (exp(-0.5) against exp(-1)).
    """
    from sail_env.physics.noise import mean_and_covariance, moment_generator, second_moment
    from sail_env.physics.planar.model import VX, push_sensitivity

    rate, psd, duration, v0 = -1.0, 1.0, 1.0, 2.0
    a = np.zeros((4, 4))
    a[VX, VX] = rate
    start = np.array([0.0, v0, 0.0, 0.0])
    gen = moment_generator(a, np.zeros((4, 2)), np.zeros(2), WhiteNoise(push_psd_s=psd),
                           push_sensitivity(a, np.zeros((4, 2))), (0,))
    mean, cov = mean_and_covariance(scipy.linalg.expm(gen * duration) @ second_moment(start, np.zeros((4, 4))))
    expected_mean = v0 * np.exp((rate + 0.5 * psd * rate**2) * duration)
    expected_square = v0**2 * np.exp(2 * (rate + psd * rate**2) * duration)
    assert mean[VX] == pytest.approx(expected_mean, rel=1e-12)
    assert cov[VX, VX] + mean[VX] ** 2 == pytest.approx(expected_square, rel=1e-12)
    for config in (SEED, DEEP_DISH):
        model = PlanarModel(config)
        a_push, b_push = push_sensitivity(model.A, model.B)
        np.testing.assert_array_equal(a_push @ a_push, 0)
        np.testing.assert_array_equal(a_push @ b_push, 0)


def test_moment_growth_rate_with_additive_noise_is_the_sails_own():
    """With additive noise only, the second moment's generator has the eigenvalues λ_i + λ_j of A's:
    half its largest real part is the sail's growth rate (``PlanarModel.stability``, from the closed-form
    roots of the 2x2 stiffness; zero for the oscillating deep dish), per model of a batch."""
    from sail_env.physics import FLAT
    from sail_env.physics.noise import moment_growth_rate

    noise = WhiteNoise(beam_jitter_psd_m2s=1e-10)
    flat, dish = PlanarModel(FLAT), PlanarModel(DEEP_DISH)
    assert flat.stability.growth_rate > 50.0 and dish.stability.growth_rate == 0.0
    assert moment_growth_rate(flat.A, flat.B, noise, flat.push_sensitivity) == pytest.approx(
        flat.stability.growth_rate, rel=1e-9)
    a, b = np.stack([flat.A, dish.A]), np.stack([flat.B, dish.B])
    batch = moment_growth_rate(a, b, noise, push_sensitivity(a, b))
    assert batch.shape == (2,)
    assert batch == pytest.approx([flat.stability.growth_rate, 0.0], rel=1e-9, abs=1e-9 * flat.stability.growth_rate)


def test_noise_validation():
    with pytest.raises(ValueError, match="push_psd_s"):
        WhiteNoise(push_psd_s=-1.0)
    with pytest.raises(ValueError, match="duration"):
        propagate_moments(PlanarModel(SEED), np.zeros(4), np.zeros((4, 4)), np.zeros(2), -1.0, WhiteNoise())
    from sail_env.analysis.planar import tolerable_jitter_psd

    for probability in (0.0, 1.0, 1.5):
        with pytest.raises(ValueError, match=rf"probability must be in \(0, 1\), got {probability}"):
            tolerable_jitter_psd(PlanarModel(SEED), 590.0, 1e-8, 600.0, probability)


def test_tolerable_jitter_matches_the_driven_oscillator():
    """At the seed point only the X oscillator feels the jitter: E[Vx²] = b² S (t/2 + sin 2ωt / 4ω)."""
    from sail_env.analysis.planar import tolerable_jitter_psd

    model = PlanarModel(SEED)
    b = model.B[1, 0]
    omega = model.stability.frequencies[0]
    t = 590.0
    unit_variance = b**2 * (t / 2 + np.sin(2 * omega * t) / (4 * omega))
    expected = (1e-8 * 6e7 / 1.959964) ** 2 / unit_variance
    assert tolerable_jitter_psd(model, t, 1e-8, 600.0) == pytest.approx(expected, rel=1e-6)
    # Check the definition by sampling: 95 % of the draws stay inside the tolerance.
    psd = tolerable_jitter_psd(model, t, 1e-8, 600.0)
    _, cov = propagate_moments(model, np.zeros(4), np.zeros((4, 4)), np.zeros(2), t, WhiteNoise(psd))
    draws = np.random.default_rng(0).normal(0, np.sqrt(cov[1, 1]), 100_000)
    assert np.mean(np.abs(draws) / 6e7 <= 1e-8) == pytest.approx(0.95, abs=0.005)


def _kron_generator(drift, mult, jitter, push_psd):
    """The vec generator written out with ``np.kron`` (one model): the reference for the batched one."""
    eye = np.eye(len(drift))
    gen = np.kron(drift, eye) + np.kron(eye, drift) + push_psd * np.kron(mult, mult)
    gen[:, -1] += jitter.ravel()
    return gen


def _random_system(rng, n, m, rate):
    """A random ``(A, B, ∂A/∂ln F, ∂B/∂ln F)`` whose fastest mode grows (``rate > 0``) or decays."""
    a = rng.standard_normal((n, n))
    a += (rate - np.linalg.eigvals(a).real.max()) * np.eye(n)
    return a, rng.standard_normal((n, m)), rng.standard_normal((n, n)), rng.standard_normal((n, m))


@pytest.mark.parametrize("n, m, jitter_inputs", [(4, 2, (0,)), (8, 4, (0, 1))])
@pytest.mark.parametrize("rate", [-0.5, 0.7])
def test_half_vectorised_generator_propagates_the_full_moments(n, m, jitter_inputs, rate):
    """The vech generator (``(n+1)(n+2)/2`` square) against the full ``(n+1)²`` one written with
    ``np.kron``, for random stable and unstable systems with multiplicative and additive noise and
    a held input: the same matrix ``L G D``, and the same moments after ``expm`` to round-off."""
    from sail_env.physics.noise import mean_and_covariance, moment_generator, second_moment, vec_moment_generator

    rng = np.random.default_rng(n + 10 * (rate > 0))
    systems = [_random_system(rng, n, m, rate) for _ in range(3)]
    a, b, a_push, b_push = (np.stack(parts) for parts in zip(*systems))
    action, psd = rng.standard_normal((3, m)), rng.uniform(0.1, 1.0, 3)
    noise = WhiteNoise(beam_jitter_psd_m2s=0.0, push_psd_s=0.3)
    args = (a, b, action, noise, (a_push, b_push), jitter_inputs, psd)
    full, half = vec_moment_generator(*args), moment_generator(*args)
    size = n + 1
    rows, cols = np.triu_indices(size)
    assert half.shape == (3, len(rows), len(rows))
    for i in range(3):
        drift, mult, jitter = (np.zeros((size, size)) for _ in range(3))
        drift[:n, :n], drift[:n, n] = a[i], b[i] @ action[i]
        mult[:n, :n], mult[:n, n] = a_push[i], b_push[i] @ action[i]
        drift += 0.5 * noise.push_psd_s * mult @ mult
        for column in jitter_inputs:
            jitter[:n, :n] += psd[i] * np.outer(b[i, :, column], b[i, :, column])
        reference = _kron_generator(drift, mult, jitter, noise.push_psd_s)
        np.testing.assert_allclose(full[i], reference, rtol=1e-14, atol=1e-15 * np.abs(reference).max())
        duplication = np.zeros((size * size, len(rows)))
        duplication[rows * size + cols, np.arange(len(rows))] = 1.0
        duplication[cols * size + rows, np.arange(len(rows))] = 1.0
        np.testing.assert_allclose(half[i], reference[rows * size + cols] @ duplication, rtol=1e-14,
                                   atol=1e-15 * np.abs(reference).max())
    mean = rng.standard_normal((3, n))
    root = rng.standard_normal((3, n, n))
    cov = root @ np.swapaxes(root, 1, 2)
    start = second_moment(mean, cov)
    full_start = np.concatenate([np.concatenate([cov + mean[:, :, None] * mean[:, None, :], mean[:, :, None]], 2),
                                 np.concatenate([mean, np.ones((3, 1))], 1)[:, None]], 1).reshape(3, -1)
    for duration in (0.3, 3.0):
        out_mean, out_cov = mean_and_covariance(np.einsum("kij,kj->ki", scipy.linalg.expm(half * duration), start))
        moved = np.einsum("kij,kj->ki", scipy.linalg.expm(full * duration), full_start).reshape(3, size, size)
        ref_mean = moved[:, :n, n]
        ref_cov = moved[:, :n, :n] - ref_mean[:, :, None] * ref_mean[:, None, :]
        scale = np.abs(moved).max()
        np.testing.assert_allclose(out_mean, ref_mean, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(out_cov, ref_cov, rtol=0, atol=1e-12 * scale)
        np.testing.assert_array_equal(out_cov, np.swapaxes(out_cov, 1, 2))


@pytest.mark.parametrize("rate", [-0.5, 0.7])
def test_moment_growth_rate_is_the_full_generators(rate):
    """The top of the spectrum lies on the symmetric moments (the generator is a Lyapunov operator plus
    a positive map), so half-vectorising keeps the growth rate: against the full generator's eigenvalues."""
    from sail_env.physics.noise import moment_growth_rate, vec_moment_generator

    rng = np.random.default_rng(3)
    for _ in range(5):
        a, b, a_push, b_push = _random_system(rng, 8, 4, rate)
        noise = WhiteNoise(push_psd_s=0.3)
        full = vec_moment_generator(a, b, np.zeros(4), noise, (a_push, b_push), (0, 1))
        expected = 0.5 * np.linalg.eigvals(full).real.max()
        assert abs(expected - rate) > 0.05  # the multiplicative noise moves it
        assert moment_growth_rate(a, b, noise, (a_push, b_push)) == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_half_vectorised_coasts_of_the_real_plants_are_the_full_ones():
    """The planar realistic task's 589 s coast and a 5 s piece of the 3D realistic task's relativistic
    coast with the ground jitter, the dust and the payload's constant term (three parameter draws each, from a state near the beam's edge): the
    plants' vech propagators against ``expm`` of the full ``(n+1)²`` generator of the same matrices in
    two sets of units (each state over its start limit, and those times random factors). In SI units
    (no balancing in :func:`moment_propagator`) the planar tilt's variance misses by ~2e-8."""
    from sail_env.envs.rigid3d import rigid3d_spec
    from sail_env.physics.linear import zoh_discretize
    from sail_env.physics.noise import mean_and_covariance, second_moment, vec_moment_generator
    from sail_env.physics.disturbances import LandingJitter
    from sail_env.physics.planar.plant import PlanarPlant
    from sail_env.tasks import TASKS

    rng = np.random.default_rng(5)
    planar_kwargs = TASKS["LightSailRealistic-v0"]
    planar = PlanarPlant(planar_kwargs["config"], planar_kwargs["parameter_spread"], planar_kwargs["push_noise"],
                         (LandingJitter(planar_kwargs["beam_jitter_m"]),))
    rigid = rigid3d_spec(**TASKS["LightSail3DRealistic-v0"]).plant
    for plant, duration, t in ((planar, 589.0, 305.0), (rigid, 5.0, 300.0)):
        k, n = 3, plant.n_states
        p = plant.params(np.stack([plant.draw(rng) for _ in range(k)]))
        x = rng.uniform(-1, 1, (k, n)) * plant.start_limits()
        u = rng.uniform(-1, 1, (k, plant.n_inputs)) * 1e-3
        (propagator,) = plant._piece_propagators(p, u, np.full((k, 1), t), np.full(k, duration))
        half = mean_and_covariance(np.einsum("kij,kj->ki", propagator, second_moment(x, np.zeros((k, n, n)))))
        q = plant._coast_params(p, u, np.full(k, t))
        push = (q.a - plant.kinematics, q.b) if plant is rigid else push_sensitivity(q.a, q.b)
        psd = plant.jitter_std(p, np.full(k, t)) ** 2 * plant.dt * np.ones((k, 1))

        def full_moments(units):
            """The moments through the full generator with the states in ``units``."""
            a, b = q.a / units[:, None] * units, q.b / units[:, None]
            impacts = plant._impact_psd(p, np.full(k, t)) if plant is rigid else None
            gen = vec_moment_generator(a, b, plant.with_bias(u), plant.white_noise,
                                       (push[0] / units[:, None] * units, push[1] / units[:, None]),
                                       plant.jitter_inputs, psd[:, 0],
                                       None if impacts is None else impacts / units[:, None] / units)
            start = np.concatenate([x / units, np.ones((k, 1))], 1)
            moved = np.einsum("kij,kj->ki", scipy.linalg.expm(gen * duration),
                              (start[:, :, None] * start[:, None, :]).reshape(k, -1)).reshape(k, n + 1, n + 1)
            mean = moved[:, :n, n]
            cov = moved[:, :n, :n] - mean[:, :, None] * mean[:, None, :]
            return mean * units, cov * units[:, None] * units

        balanced = full_moments(plant.start_limits())
        other = full_moments(plant.start_limits() * rng.uniform(0.2, 5.0, n))
        # Errors on the scale of the second moments (the covariance M − m mᵀ inherits M's).
        second = np.sqrt(np.diagonal(balanced[1], axis1=1, axis2=2) + balanced[0] ** 2)
        scale = second[:, :, None] * second[:, None, :]
        assert np.all(np.diagonal(balanced[1], axis1=1, axis2=2) > 1e-6 * second**2)  # the noise is no round-off
        for mean, cov in (half, other):
            np.testing.assert_allclose(mean / second, balanced[0] / second, rtol=0, atol=1e-10)
            np.testing.assert_allclose(cov / scale, balanced[1] / scale, rtol=0, atol=2e-10)
        if plant is planar:  # A_F² = 0: the noise-free mean is the exact one (~65,000 rad of phase)
            phi, gamma = zoh_discretize(p.a, p.b, duration)
            exact = np.einsum("kij,kj->ki", phi, x) + np.einsum("kij,kj->ki", gamma, u)
            np.testing.assert_allclose(half[0] / second, exact / second, rtol=0, atol=2e-10)


@pytest.mark.parametrize("n, m, jitter_inputs", [(4, 2, (0,)), (8, 4, (0, 1))])
def test_the_held_input_generator_gives_every_inputs_generator(n, m, jitter_inputs):
    """``R G L(u)`` of the held-input generator (the input as constant states) is the generator of
    input ``u`` (random systems with push noise, beam jitter and a state noise), and its exponential
    moves the lifted moments of ``(s, u, 1)`` as the input's moves those of ``(s, 1)``."""
    from sail_env.physics.noise import (held_input_generator, held_input_maps, mean_and_covariance,
                                        moment_generator, second_moment)

    rng = np.random.default_rng(n)
    systems = [_random_system(rng, n, m, -0.3) for _ in range(3)]
    a, b, a_push, b_push = (np.stack(parts) for parts in zip(*systems))
    psd, noise = rng.uniform(0.1, 1.0, 3), WhiteNoise(push_psd_s=0.2)
    root = rng.standard_normal((3, n, n))
    state_psd = root @ np.swapaxes(root, 1, 2)
    held = held_input_generator(a, b, noise, (a_push, b_push), jitter_inputs, psd, state_psd)
    assert held.shape == (3, (n + m + 1) * (n + m + 2) // 2, (n + m + 1) * (n + m + 2) // 2)
    pick, lift0, lift1, lift2 = held_input_maps(n, m)
    for u in (np.zeros((3, m)), rng.standard_normal((3, m))):
        lift = lift0 + np.einsum("kj,jab->kab", u, lift1) + np.einsum("ki,kj,ijab->kab", u, u, lift2)
        direct = moment_generator(a, b, u, noise, (a_push, b_push), jitter_inputs, psd, state_psd)
        reduced = pick @ held @ lift
        np.testing.assert_allclose(reduced, direct, rtol=0, atol=1e-14 * np.abs(direct).max())
        start = second_moment(rng.standard_normal((3, n)), np.zeros((3, n, n)))
        moved = mean_and_covariance(np.einsum("kij,kj->ki", scipy.linalg.expm(reduced * 2.0), start))
        reference = mean_and_covariance(np.einsum("kij,kj->ki", scipy.linalg.expm(direct * 2.0), start))
        for ours, theirs in zip(moved, reference):
            np.testing.assert_allclose(ours, theirs, rtol=1e-10, atol=1e-12 * np.abs(theirs).max())


def test_a_constant_input_column_joins_the_held_generators_constant():
    """``held=m − 1``: the last column of ``B`` an input at 1 (a plant's constant term), not a held state: ``R G L(u)``
    is the generator of the input ``(u, 1)``, in NumPy and in JAX alike."""
    from sail_env.physics.noise import held_input_generator, held_input_maps, moment_generator

    n, m = 8, 5
    rng = np.random.default_rng(3)
    a, b, a_push, b_push = _random_system(rng, n, m, -0.3)
    noise, psd = WhiteNoise(push_psd_s=0.2), 0.4
    held = held_input_generator(a, b, noise, (a_push, b_push), (0, 1), psd, held=m - 1)
    assert held.shape == ((n + m) * (n + m + 1) // 2,) * 2  # (s, u, 1): no state for the constant column
    pick, lift0, lift1, lift2 = held_input_maps(n, m - 1)
    u = rng.standard_normal(m - 1)
    lift = lift0 + np.tensordot(u, lift1, 1) + np.tensordot(np.outer(u, u), lift2, 2)
    direct = moment_generator(a, b, np.append(u, 1.0), noise, (a_push, b_push), (0, 1), psd)
    np.testing.assert_allclose(pick @ held @ lift, direct, rtol=0, atol=1e-14 * np.abs(direct).max())
    pytest.importorskip("sail_env.jax")  # JAX with float64 (the backend turns it on)
    import jax.numpy as jnp

    in_jax = held_input_generator(jnp.asarray(a), jnp.asarray(b), noise, (jnp.asarray(a_push), jnp.asarray(b_push)),
                                  (0, 1), psd, held=m - 1, xp=jnp)
    np.testing.assert_allclose(np.asarray(in_jax), held, rtol=0, atol=1e-14 * np.abs(held).max())
