"""The compiled core's seams: the episode state's documented fields, the plant's divergence rule
as data, success and the delay rule each decided in one place, and the kernels' logic run as
plain Python (``NUMBA_DISABLE_JIT=1``)."""

import dataclasses
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numba
import numpy as np
import pytest

import sail_env  # noqa: F401
from sail_env.core.delay import arrived_command
from sail_env.core.episode import EpisodeCore
from sail_env.core.reward import LOG_RATIO_RANGE, log10, log_ratio, succeeded
from sail_env.core.state import FIELDS, SIZES, EpisodeState, Slot, field_shape
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD

ROOT = Path(__file__).parents[2]


def test_every_field_of_the_episode_state_is_documented_and_a_view_of_its_buffer():
    doc = EpisodeState.__doc__
    core = gym.make_vec("LightSailRealistic-v0", num_envs=3, vectorization_mode="vector_entry_point").unwrapped.core
    for field in dataclasses.fields(EpisodeState):
        if field.name in ("floats", "ints", "layout"):
            continue
        assert re.search(rf"\b{field.name}\b", doc), field.name
        value = getattr(core.state, field.name)
        if isinstance(value, np.ndarray):
            assert len(value) == 3, field.name
            if value.size:
                assert np.shares_memory(value, core.state.floats) or np.shares_memory(value, core.state.ints), field.name


@pytest.mark.parametrize("env_id", ["LightSailRealistic-v0", "LightSailUncertain-v1"])
def test_the_state_follows_its_one_declaration(env_id):
    """Each declared field is the state's attribute of its dtype and shape, and the fields tile each
    environment's record of their buffer in the declared order; the layout holds the sizes, the offsets,
    the records' lengths and the tables, in that order."""
    core = gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point").unwrapped.core
    state, layout = core.state, core.state.layout
    assert [f.name for f in dataclasses.fields(EpisodeState)][:len(FIELDS)] == [f.name for f in FIELDS]
    assert [s.name for s in Slot] == [*SIZES, *(f.offset for f in FIELDS), "FLOAT_RECORD", "INT_RECORD",
                                      "TABLES"]
    for dtype, buffer, record in (("float64", state.floats, Slot.FLOAT_RECORD),
                                  ("int64", state.ints, Slot.INT_RECORD)):
        fields = [f for f in FIELDS if f.dtype == dtype]
        assert buffer.dtype == dtype and buffer.shape == (3 * layout[record],)
        offset = 0
        for field in fields:
            value = getattr(state, field.name)
            assert value.dtype == dtype and value.shape == (3, *field_shape(field, layout)), field.name
            assert layout[Slot[field.offset]] == offset, field.name
            offset += value[0].size
            value[...] = np.arange(value.size).reshape(value.shape) + 1  # each element lands in its own place
        assert offset == layout[record]
        records = buffer.reshape(3, -1)
        assert np.array_equal(records, np.concatenate([getattr(state, f.name).reshape(3, -1) for f in fields], 1))


def test_the_envs_and_agents_read_the_core_only_through_its_state():
    """Outside the core nothing reaches into ``core.<array>``: the documented state is the interface."""
    users = [*(ROOT / "sail_env" / "envs").glob("*.py"), *(ROOT / "agents").glob("*.py")]
    allowed = {"state", "step", "reset", "observe"}
    reached = {(path.name, name) for path in users for name in re.findall(r"\b(?:self|unwrapped|envs|env)\.core\.([a-z_]\w*)", path.read_text())
               if name not in allowed}
    assert not reached


@pytest.mark.parametrize("env_id", ["LightSailRealistic-v0", "LightSail3D-v0"])
def test_the_compiled_step_applies_the_divergence_rule_the_plant_declares(env_id):
    """States around the limits: the kernel's divergence is the plant's declared rule (NumPy) on the
    state it reached, group by group (a box in the plane, radial in 3D)."""
    n = 1000
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point").unwrapped
    envs.reset(seed=1)
    plant, state = envs.episode_spec.plant, envs.state
    assert plant.divergence_groups == (((0,), (2,)) if plant.n_states == 4 else ((0, 1), (4, 5)))
    limits = state.params.limits
    rng = np.random.default_rng(0)
    start = np.zeros((n, plant.n_states))
    for column, rows in enumerate(plant.divergence_groups):
        start[:, list(rows)] = rng.uniform(-1.0, 1.0, (n, len(rows))) * limits[:, column][:, None]
    state.x[:] = start
    result = envs.core.step(np.zeros((n, plant.n_inputs)))
    expected = plant.diverged(state.params, state.x)
    assert 0.05 < expected.mean() < 0.95
    np.testing.assert_array_equal(result.diverged.astype(bool), expected)


def test_success_is_decided_in_one_place():
    users = [*(ROOT / "sail_env").rglob("*.py"), *(ROOT / "agents").glob("*.py")]
    deciding = sorted(str(path.relative_to(ROOT)) for path in users if path.name != "paper.py"
                      and re.search(r"<=\s*POINTING_TOLERANCE_RAD", path.read_text()))
    assert deciding == ["sail_env/core/reward.py"]
    assert list(succeeded(np.array([0.0, POINTING_TOLERANCE_RAD, 2e-8, np.inf, np.nan]))) == [True, True, False,
                                                                                             False, False]


def test_log_ratio_is_clipped_and_keeps_nan():
    values = log_ratio(np.array([0.0, 1e-8, 1e-7, 1.0, np.nan]))
    np.testing.assert_array_equal(values[:4], [-2.0, 0.0, 1.0, 3.0])
    assert np.isnan(values[4])


@numba.njit
def _log10_of_each(x: np.ndarray, out: np.ndarray) -> None:
    for i in range(x.shape[0]):
        out[i] = log10(x[i])


def test_the_rewards_log10_is_the_c_librarys_to_two_units_in_the_last_place():
    """The reward's arithmetic ``log10`` against the C library's (``math.log10``) on doubles drawn
    uniformly where the reward keeps the ratio (0.01 … 1000) and over every binade of the positive
    normal numbers, with the mantissa's edges (√2, where the argument is halved)."""
    rng = np.random.default_rng(2)
    kept = rng.uniform(0.01, 1000.0, 300_000)
    every = np.ldexp(rng.uniform(1.0, 2.0, 300_000), rng.integers(-1021, 1024, 300_000))
    edges = np.concatenate([np.nextafter(np.sqrt(2.0), [0.0, 2.0]) * 2.0 ** k for k in range(-3, 4)])
    for x in (kept, every, edges, np.array([1.0, 2.0, 10.0, 1e-292, np.finfo(float).max, np.finfo(float).tiny])):
        ours = np.empty_like(x)
        _log10_of_each(x, ours)
        library = np.array([math.log10(value) for value in x])
        assert np.all(np.abs(ours - library) <= 2 * np.spacing(np.abs(library)))
    _log10_of_each(kept, ours := np.empty_like(kept))
    assert np.mean(ours == np.array([math.log10(value) for value in kept])) > 0.95
    _log10_of_each(np.array([np.inf]), ours[:1])
    assert ours[0] > LOG_RATIO_RANGE[1]


def test_the_delay_rule_gives_the_newest_arrived_command():
    assert arrived_command(5, 2, 10) == 3  # sent at step 3 arrives at step 5
    assert arrived_command(5, 2, 1) == 1  # no newer one was sent
    assert arrived_command(1, 2, 10) == -1  # nothing has arrived yet
    assert arrived_command(3, 0, -1) == -1  # nothing sent


def test_a_batch_reset_draws_what_each_environment_would_alone():
    """One uniform call and one normal call per environment draw the numbers separate calls draw."""
    spec = gym.make("LightSailRealistic-v0").unwrapped.episode_spec
    batch, single = EpisodeCore(spec, 3), EpisodeCore(spec, 1)
    batch.reset(np.arange(3), [np.random.default_rng(s) for s in (7, 8, 9)])
    single.reset(np.arange(1), [np.random.default_rng(8)])
    for name in ("x", "cutoff_s", "normals", "delay", "lag0"):
        np.testing.assert_array_equal(getattr(batch.state, name)[1], getattr(single.state, name)[0], err_msg=name)


#: A few tests of tests/core and tests/envs, run with the kernels as plain Python.
SUBSET = ["tests/core/test_same_numbers.py::test_noise_free_episodes_are_those_of_v0_1_0[LightSail-v0|delay10s]",
          "tests/core/test_recorded_noisy_episodes.py::test_noisy_episodes_are_those_recorded[v0.2.0-LightSail3DRealistic-v1-3]",
          "tests/core/test_compiled_core.py::test_the_compiled_step_applies_the_divergence_rule_the_plant_declares"
          "[LightSail3D-v0]",
          "tests/core/test_limits.py::test_vector_env_refuses_non_finite_actions_and_a_step_before_reset",
          "tests/core/test_compiled_core.py::test_a_block_of_environments_steps_each_as_alone_to_the_bit[LightSail-v0]"]


@pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT") == "1", reason="already running without the compiler")
def test_the_kernels_logic_runs_as_python_with_the_same_results():
    """``NUMBA_DISABLE_JIT=1`` runs the kernels' source as Python: the recorded episodes and the
    env's tests pass that way too (so coverage and mutation tools see the step's logic)."""
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *SUBSET],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert " passed" in done.stdout and "failed" not in done.stdout


@pytest.mark.parametrize("env_id, keywords", [("LightSail-v0", {}), ("LightSail3D-v0", {}),
                                              ("LightSailRealistic-v0", {}),
                                              ("LightSailRealistic-v0", {"parameter_spread": 0.0})],
                         ids=["LightSail-v0", "LightSail3D-v0", "LightSailRealistic-v0", "LightSailRealistic-v0-shared"])
def test_a_block_of_environments_steps_each_as_alone_to_the_bit(env_id, keywords):
    """The step runs its stages across a block of environments (one shared model) or one
    environment at a time (a model per environment, or a few environments): the same sums in the
    same order, so every environment of a batch spanning two blocks and a short one gives the single
    env's observations and rewards to the last bit. The realistic task without its parameter spread
    shares one model with push noise (the step's Horner scheme across the block)."""
    from sail_env.core.kernels import BLOCK
    n, steps, seed = 2 * BLOCK + 3, 30, 4
    actions = np.random.default_rng(1).uniform(-1.2, 1.2, (steps, n, 2)).astype(np.float32)
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **keywords)
    m = envs.single_action_space.shape[0]
    batch = [envs.reset(seed=seed)[0]]
    rewards = []
    for k in range(steps):
        obs, reward, *_ = envs.step(np.resize(actions[k], (n, m)))
        batch.append(obs)
        rewards.append(reward)
    batch, rewards = np.array(batch), np.array(rewards)
    for i in (0, 1, BLOCK - 1, BLOCK, 2 * BLOCK + 1, n - 1):
        env = gym.make(env_id, **keywords)
        alone = [env.reset(seed=seed + i)[0]]
        for k in range(steps):
            obs, reward, *_ = env.step(np.resize(actions[k], (n, m))[i])
            alone.append(obs)
            assert reward == rewards[k, i], (i, k)
        np.testing.assert_array_equal(np.array(alone), batch[:, i])
