"""The plant's small matrix work runs with one BLAS thread whatever the caller's setting
(sail_env.physics.blas, docs/physics.md §3): inside the coast, the parameter build and a batched
step the BLAS libraries report one thread, and the caller's count is back afterwards."""

from __future__ import annotations

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from sail_env.physics.blas import blas_threads, one_blas_thread
from sail_env.physics.linear_plant import THREADED_BATCH
from sail_env.physics.disturbances import GroundJitter
from sail_env.physics.rigid3d.plant import RigidTaskConfig, RigidPlant
from sail_env.physics.rigid3d.config import RigidSailConfig


@pytest.fixture()
def two_threads():
    """The BLAS libraries at two threads (skipped where a library will not take two)."""
    with threadpool_limits(2, user_api="blas"):
        if min(blas_threads()) < 2:
            pytest.skip("the BLAS libraries here run one thread only")
        yield


def test_context_limits_and_restores(two_threads):
    with one_blas_thread():
        assert blas_threads() == [1] * len(blas_threads())
    assert min(blas_threads()) == 2


def test_coast_build_and_batched_step_run_single_threaded(two_threads, monkeypatch):
    flight = RigidTaskConfig(RigidSailConfig(curvature_radius_m=4.0), relativistic=True)
    plant = RigidPlant(flight, parameter_spread=0.1, push_noise=0.01, disturbances=(GroundJitter(1e-15),))
    seen = {}

    def spy(name, method):
        def wrapped(*args, **kwargs):
            seen.setdefault(name, []).append(max(blas_threads()))
            return method(*args, **kwargs)
        monkeypatch.setattr(plant, name, wrapped)

    spy("_piece_propagators", plant._piece_propagators)
    spy("_build", plant._build)
    k = THREADED_BATCH
    p = plant.params(np.ones((k, plant.n_factors)))
    x = np.zeros((k, plant.n_states))
    u = np.zeros((k, plant.n_inputs))
    assert max(blas_threads()) == 2
    normals = np.zeros((k, int(plant.coast_pieces(p, np.full(k, 30.0)).max()), plant.n_states))
    plant.coast(p, x, u, np.full(k, 30.0), normals, np.full(k, 10.0))
    assert seen["_build"] == [1] and seen["_piece_propagators"] and set(seen["_piece_propagators"]) == {1}
    assert min(blas_threads()) == 2
    # The batched step's product: numpy's matmul reaches BLAS, which must see one thread.
    monkeypatch.setattr(np, "matmul", _recording(np.matmul, seen.setdefault("matmul", [])))
    plant.step(p, x, u, np.zeros(k))
    assert seen["matmul"] and set(seen["matmul"]) == {1}
    assert min(blas_threads()) == 2


def _recording(function, log):
    def wrapped(*args, **kwargs):
        log.append(max(blas_threads()))
        return function(*args, **kwargs)
    return wrapped
