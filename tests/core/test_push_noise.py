"""The per-step push-noise propagator (second-order expansion) against exact exponentials."""

import numpy as np
import pytest
import scipy.stats

from sail_env.envs.planar import planar_spec
from sail_env.physics import DEEP_DISH
from sail_env.physics.linear import zoh_discretize
from sail_env.physics.planar.model import push_sensitivity


def _window(spec, x0, actions, normals, exact):
    """The control window's end states with per-step push errors σ·normals, exact or expanded."""
    plant, sigma = spec.plant, spec.randomisation.push_noise
    params = plant.params(np.ones((1, 5)))
    a_push, b_push = push_sensitivity(params.a[0], params.b[0])
    x = x0.copy()
    for k in range(actions.shape[1]):
        eps = sigma * normals[:, k]
        if exact:
            phi, gamma = zoh_discretize(params.a[0] + eps[:, None, None] * a_push, (1 + eps[:, None, None]) * b_push,
                                        spec.dt)
            x = np.einsum("nij,nj->ni", phi, x) + np.einsum("nij,nj->ni", gamma, actions[:, k])
        else:
            x = plant.step(params, x, actions[:, k], eps)
    return x


def test_expanded_push_noise_follows_the_exact_path_and_distribution():
    spec = planar_spec(DEEP_DISH, push_noise=0.01)
    rng = np.random.default_rng(0)
    n, steps = 1000, spec.n_steps // 2
    x0 = rng.uniform(-spec.start_half_widths, spec.start_half_widths, (n, 4))
    actions = rng.uniform(-1, 1, (n, steps, 2)) * spec.action_scale
    normals = rng.standard_normal((n, steps))
    exact = _window(spec, x0, actions, normals, exact=True)
    fast = _window(spec, x0, actions, normals, exact=False)
    # Same noise draws: the paths agree to the third-order remainder, ~1e-7 of the state's size.
    scale = np.abs(exact).max(axis=0)
    assert np.abs(fast - exact).max(axis=0) / scale == pytest.approx(0, abs=1e-6)
    # The noise itself moves the end states by far more than that (the test has power).
    quiet = _window(spec, x0, actions, np.zeros((n, steps)), exact=False)
    assert (np.abs(exact - quiet).max(axis=0) / scale).min() > 1e-2
    # Independent draws: no difference in distribution a two-sample KS test can see.
    other = _window(spec, x0, actions, rng.standard_normal((n, steps)), exact=True)
    for k in range(4):
        assert scipy.stats.ks_2samp(fast[:, k] - quiet[:, k], other[:, k] - quiet[:, k]).pvalue > 1e-3
