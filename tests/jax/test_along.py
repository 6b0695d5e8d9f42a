"""The coast along the flight (sail_env/jax/along.py) against the plant it ports: each piece's model and
moment generator against ``RigidPlant._coast_params`` and ``_moment_generator`` at times before, at and
beyond the spot's widening, the Padé exponential against SciPy's, and a whole coast against the plant's
``coast`` fed the same normals."""

from __future__ import annotations

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("gymnax")

import jax.numpy as jnp  # noqa: E402
import sail_env.jax  # noqa: E402
import scipy.linalg  # noqa: E402

from sail_env.envs.rigid3d import rigid3d_spec  # noqa: E402
from sail_env.jax.along import MAX_SQUARINGS, THETA13, Coast, along_of, expm  # noqa: E402
from sail_env.physics.noise import balancing  # noqa: E402
from sail_env.tasks import RIGID3D_TASKS  # noqa: E402

DRAWS = 6


#: The fastest draw of each task: the lightest sail under the strongest beam (and, uncertain, the most power
#: reaching it, the nominal dish, the largest beam offsets): its spot widens from ~585 s (uncertain: ~510 s).
FASTEST = {"LightSail3DRealistic-v1": [0.9, 1.0, 1.1], "LightSailUncertain-v1": [0.9, 1.0, 1.1, 1.0, 1.0, 1.2, 2.0, 0.0],
           "LightSailUncertain-v2": [0.9, 1.0, 1.1, 1.0, 1.0, 1.2, 2.0, 0.0]}


@pytest.fixture(scope="module", params=list(FASTEST))
def task(request):
    """A realistic 3D task's plant and the models of six draws (the uncertain tasks': each its own sail), the
    fastest among them, with random commands."""
    spec = rigid3d_spec(**RIGID3D_TASKS[request.param])
    plant = spec.plant
    rng = np.random.default_rng(0)
    factors = plant.factors(rng.random((DRAWS, plant.n_draws)))
    factors[0] = FASTEST[request.param]
    p = plant.params(factors)
    u = rng.uniform(-1, 1, (DRAWS, plant.n_inputs)) * spec.action_scale
    return spec, plant, p, u, along_of(plant.flight_model(p), jnp.float64), Coast(plant, plant.flight_model(p))


@pytest.mark.parametrize("t", [12.0, 300.0, 595.0, 604.0])
def test_each_pieces_model_and_generator_are_the_plants(task, t):
    """To rounding (measured ≤ 2e-16 of the largest entry); the fastest draw's spot has widened at 595 s
    and 604 s (from ~585 s), so both of the plant's branches are compared."""
    _, plant, p, u, along, coast = task
    times = np.full(DRAWS, t)
    q = plant._coast_params(p, u, times)
    a, b = jax.vmap(coast.piece_model, in_axes=(None, 0, None))(along, jnp.arange(DRAWS), t)
    generator = jax.vmap(coast.generator, in_axes=(None, 0, 0, None))(along, jnp.arange(DRAWS), jnp.asarray(u), t)
    for got, want in ((a, q.a), (b, q.b), (generator, plant._moment_generator(q, u, times))):
        assert np.abs(np.asarray(got) - want).max() <= 1e-14 * np.abs(want).max()
    if t > 590:
        ratio = p.acceleration / plant.nominal_acceleration
        assert plant.flights.beam_scale(ratio, times)[0] > 1.0


def test_the_pade_exponential_is_scipys(task):
    """The pieces' balanced generators (5 s, and a 0.3 s remnant): within 5e-11 of SciPy's ``expm``
    (measured ≤ 1.5e-11; JAX's own ``expm`` 2.3e-11), and NaN where the squarings do not suffice."""
    spec, plant, p, u, _, _ = task
    into, _ = balancing(plant.start_limits())
    for t, length in ((11.0, 4.98), (590.0, 5.0), (600.0, 0.3)):
        q = plant._coast_params(p, u, np.full(DRAWS, t))
        balanced = plant._moment_generator(q, u, np.full(DRAWS, t)) * (length * into)
        want = scipy.linalg.expm(balanced)
        got = np.asarray(jax.vmap(expm)(jnp.asarray(balanced)))
        assert np.all(np.abs(got - want).max(axis=(1, 2)) <= 5e-11 * np.abs(want).max(axis=(1, 2)))
    beyond = jnp.eye(3) * THETA13 * 2.0 ** (MAX_SQUARINGS + 1)
    assert np.isnan(np.asarray(expm(beyond))).all()


def test_a_whole_coast_is_the_plants(task):
    """From 11 s to a cut-off of 595–605 s (119–120 pieces, the fastest draw's split where its spot starts
    widening) with the same normals: the state at cut-off within 1e-6 of the state's scales and the
    pointing within 1e-6 relative (measured 9e-8: each backend's own exponential of every piece, ~1e-11
    apart, grows with the dynamics over 600 s)."""
    spec, plant, p, u, along, coast = task
    from sail_env.physics.linear import sample_gaussian
    from sail_env.physics.noise import mean_and_covariance

    rng = np.random.default_rng(1)
    x = spec.start_half_widths * rng.uniform(-0.03, 0.03, (DRAWS, plant.n_states))
    start = np.full(DRAWS, 11.0)
    duration = 600.0 - start + rng.uniform(-5, 5, DRAWS)
    normals = rng.standard_normal((DRAWS, 125, plant.n_states))
    want, lost = plant.coast(p, x, u, duration, normals, start)
    into, back = (jnp.asarray(a) for a in balancing(plant.start_limits()))

    def sample(moments, _, drawn):
        mean, cov = mean_and_covariance(moments)
        return sample_gaussian(mean, cov, drawn, xp=jnp)

    def diverged(state):
        return ~((jnp.hypot(state[0], state[1]) <= p.limits[0, 0]) & (jnp.hypot(state[4], state[5]) <= p.limits[0, 1]))

    got, got_lost = jax.jit(jax.vmap(lambda d, *a: coast.coast(along, d, *a, into, back, sample, diverged)))(
        jnp.arange(DRAWS), jnp.asarray(x), jnp.asarray(u), jnp.asarray(start), jnp.asarray(duration),
        jnp.asarray(normals))
    got = np.asarray(got)
    np.testing.assert_array_equal(np.asarray(got_lost), lost)
    np.testing.assert_allclose(got / spec.state_scale, want / spec.state_scale, rtol=1e-6, atol=1e-6)
    pointing, reference = np.hypot(got[:, 2], got[:, 3]), np.hypot(want[:, 2], want[:, 3])
    np.testing.assert_allclose(pointing, reference, rtol=1e-6)


def test_a_bank_whose_pieces_need_more_squarings_is_refused(monkeypatch):
    """v1's 5 s pieces need up to 9.8 squarings: with 9 the bank is refused by name (``along.expm`` would
    give NaN, ending the episode as a divergence), with the default 12 it is built."""
    from sail_env.jax import along

    monkeypatch.setattr(along, "MAX_SQUARINGS", 9)
    with pytest.raises(ValueError, match="squarings of their exponential"):
        sail_env.jax.make("LightSail3DRealistic-v1", draws=8)
    monkeypatch.undo()
    sail_env.jax.make("LightSail3DRealistic-v1", draws=8)
