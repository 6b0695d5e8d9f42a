"""The second-moment generator built by JAX: :func:`~sail_env.physics.noise.moment_generator` with
``xp=jax.numpy`` under ``jit(vmap(…))``, one model per environment (as a coast whose model changes along
the flight needs it), against the NumPy path of the same code.

On the realistic tasks' models (parameter draws, inputs in the action box, flight times along the beam)
and on a random dense one (the push noise's drift ``½ S_F Ã_F²``, zero for both sails, at work), the
generators are equal to the bit where no sum in them has more than two nonzero terms: the planar task
(two inputs), the 3D task with one input at a time (and its constant term). Elsewhere they differ in the
last bits of ``B u`` and ``Ã_F²``: NumPy's ``einsum`` sums ``B u`` in SIMD lanes (this machine's
NumPy: ``((b₀u₀ + b₂u₂) + b₄u₄) + (b₁u₁ + b₃u₃)``), XLA's dot in another order, and neither can be asked
for the other's. The bound is a reordered sum's: a few ulps of the generator built of the magnitudes. The
exponential of JAX's generator moves the moments as NumPy's propagator does, to the two matrix
exponentials' own difference (the generators' share of it is ~1e-15).
"""

from __future__ import annotations

import functools
import os

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("gymnax")

import jax.numpy as jnp  # noqa: E402
import jax.scipy.linalg  # noqa: E402

from sail_env.envs.planar import planar_spec  # noqa: E402
from sail_env.envs.rigid3d import rigid3d_spec  # noqa: E402
from sail_env.jax.env import MAX_SQUARINGS  # noqa: E402  (importing sail_env.jax turns float64 on)
from sail_env.physics.noise import (WhiteNoise, balancing, mean_and_covariance, moment_generator,  # noqa: E402
                                    moment_propagator, second_moment)
from sail_env.tasks import PLANAR_TASKS, RIGID3D_TASKS  # noqa: E402

#: Models per case: distinct from every axis length of the arguments (``_jax_generators`` tells the
#: per-model arguments by it).
MODELS = 24
EXACT = "--xla_cpu_max_isa=AVX" in os.environ.get("XLA_FLAGS", "")


@functools.cache
def _spec(case: str):
    """The task of a case: the planar or the 3D realistic one (its tables built once)."""
    if case == "planar":
        return planar_spec(**PLANAR_TASKS["LightSailRealistic-v0"])
    return rigid3d_spec(**RIGID3D_TASKS["LightSail3DRealistic-v1"])


def _terms(case: str, seed: int = 0) -> tuple:
    """:func:`moment_generator`'s arguments for :data:`MODELS` models: a realistic task's plant
    (``_moment_terms``) at parameter draws, inputs in the action box (one nonzero per model for
    ``"3d one input"``) and flight times along the beam; or a random dense model (``"random"``) with
    every term of the generator at work (beam jitter from ``noise``, a state noise)."""
    rng = np.random.default_rng(seed)
    if case == "random":
        n, m = 8, 5
        a, b, a_push, b_push = (rng.standard_normal((MODELS, n, cols)) for cols in (n, m, n, m))
        root = rng.standard_normal((MODELS, n, n))
        return (a, b, rng.standard_normal((MODELS, m)), WhiteNoise(beam_jitter_psd_m2s=0.7, push_psd_s=0.3),
                (a_push, b_push), (0, 1), None, root @ np.swapaxes(root, 1, 2))
    spec = _spec(case.split()[0])
    plant = spec.plant
    p = plant.params(plant.factors(rng.random((MODELS, plant.n_draws))))
    u = rng.uniform(-1, 1, (MODELS, plant.n_inputs)) * spec.action_scale
    if case == "3d one input":
        u *= np.arange(plant.n_inputs) == rng.integers(0, plant.n_inputs, (MODELS, 1))
    t = rng.uniform(spec.config.control_start_s, spec.config.beam_cutoff_s, MODELS)
    return plant._moment_terms(plant._coast_params(p, u, t), u, t)


def _jax_generators(terms: tuple) -> np.ndarray:
    """``jit(vmap(moment_generator(…, xp=jnp)))`` of the models of ``terms``: an array leading with
    :data:`MODELS` is per model, anything else (the planar task's jitter PSD, a float) shared; all traced."""
    a, b, action, noise, push, jitter_inputs, jitter_psd, state_psd = terms
    arrays = (a, b, action, push, jitter_psd, state_psd)
    axes = jax.tree.map(lambda leaf: 0 if np.ndim(leaf) and np.shape(leaf)[0] == MODELS else None, arrays)

    def one(a, b, action, push, jitter_psd, state_psd):
        return moment_generator(a, b, action, noise, push, jitter_inputs, jitter_psd, state_psd, xp=jnp)

    return np.asarray(jax.jit(jax.vmap(one, in_axes=axes))(*arrays))


def _magnitudes(terms: tuple) -> np.ndarray:
    """The generator of the arguments' magnitudes: each entry the sum of its terms' magnitudes, the
    scale of its rounding errors."""
    a, b, action, noise, (a_push, b_push), jitter_inputs, jitter_psd, state_psd = terms
    return moment_generator(np.abs(a), np.abs(b), np.abs(action), noise, (np.abs(a_push), np.abs(b_push)),
                            jitter_inputs, jitter_psd, None if state_psd is None else np.abs(state_psd))


@pytest.mark.parametrize("case, order_free", [("planar", True), ("3d one input", True), ("3d", False),
                                              ("random", False)])
def test_jax_generator_is_numpys(case: str, order_free: bool) -> None:
    """Per model under ``jit(vmap)``, traced PSDs included: within ``(n + m)`` ulps of the magnitudes'
    generator (a reordered sum of ``k`` terms moves by at most ``k − 1`` of them, and ``B u`` and
    ``Ã_F²`` are the only sums), zero where that is zero; to the bit where no sum has three terms
    (under the XLA flag of ``conftest.py``: no fused multiply-adds)."""
    terms = _terms(case)
    expected, generator = moment_generator(*terms), _jax_generators(terms)
    n, m = terms[1].shape[-2:]
    assert generator.shape == expected.shape == (MODELS, (n + 1) * (n + 2) // 2, (n + 1) * (n + 2) // 2)
    assert np.all(np.abs(generator - expected) <= (n + m) * np.finfo(float).eps * _magnitudes(terms))
    if order_free and EXACT:
        np.testing.assert_array_equal(generator, expected)
    if case == "random":  # a batch in one call, without vmap, is the same code
        batched = jax.jit(functools.partial(moment_generator, noise=terms[3], jitter_inputs=terms[5], xp=jnp))
        a, b, action, _, push, _, jitter_psd, state_psd = terms
        together = np.asarray(batched(a, b, action, push=push, jitter_psd=jitter_psd, state_psd=state_psd))
        assert np.all(np.abs(together - expected) <= (n + m) * np.finfo(float).eps * _magnitudes(terms))


@pytest.mark.parametrize("case, duration, tolerance", [("3d", 5.0, 5e-11), ("planar", 589.0, 5e-10)])
def test_jax_generators_exponential_moves_the_moments_as_numpys_propagator(case: str, duration: float,
                                                                             tolerance: float) -> None:
    """A 5 s piece of the 3D coast and the planar task's whole coast (589 s), the exponential taken as
    the JAX coast takes it (balanced, :data:`~sail_env.jax.env.MAX_SQUARINGS`), against
    :func:`moment_propagator`. JAX's generator moves JAX's exponential from that of NumPy's generator by
    less than 4e-15 of its largest entry (measured 8e-16 and 0); the rest is the two matrix exponentials'
    difference, which grows with the balanced generator's norm (~5e3 and ~5e5; measured 1.1e-11 and
    2.5e-10 of the largest entry); the means drawn from agree within 5e-11 of each state's root mean
    square (measured 3e-12 and 2e-11)."""
    plant = _spec(case).plant
    terms = _terms(case, seed=1)
    into, back = balancing(plant.start_limits())
    exponential = jax.jit(jax.vmap(lambda g: jax.scipy.linalg.expm(g * (duration * into), max_squarings=MAX_SQUARINGS)))
    numpy_generator = moment_generator(*terms)
    ours, of_numpys = np.asarray(exponential(_jax_generators(terms))), np.asarray(exponential(numpy_generator))
    theirs = moment_propagator(numpy_generator, np.full(MODELS, duration), plant.start_limits()) / back  # exact
    largest = np.abs(theirs).max(axis=(1, 2))[:, None, None]
    assert np.all(np.abs(ours - of_numpys) <= 4e-15 * largest)
    assert np.all(np.abs(ours - theirs) <= tolerance * largest)
    n = plant.n_states
    x = np.random.default_rng(2).uniform(-0.5, 0.5, (MODELS, n)) * plant.start_limits()
    start = second_moment(x, np.zeros((MODELS, n, n)))
    (mean, _), (expected, cov) = (mean_and_covariance(np.einsum("kij,kj->ki", e * back, start)) for e in (ours, theirs))
    rms = np.sqrt(np.diagonal(cov, axis1=1, axis2=2) + expected**2)
    assert np.all(np.diagonal(cov, axis1=1, axis2=2) > 1e-4 * rms**2)  # the noise is no round-off
    assert np.all(np.abs(mean - expected) <= 5e-11 * rms)
