"""The noisy tasks against episodes recorded with lightsail-gym 0.2.0 (tests/data/episodes_v0_2_0.json).

The episodes draw every disturbance (sensor noise, jitter, push noise, dust, parameter spread,
cut-off time, the coast's end state), so they pin the sampler and the order of the draws: a change
that alters them is a new env version. Regenerate (only with a new version):
``python tests/core/test_recorded_noisy_episodes.py``.

Tolerances: the same machine reproduces them to the last bit; another CPU's BLAS kernel rounds the
last bits of a product differently, which the coast's ~40,000 rad of phase amplifies (the
cross-kernel benchmark measured < 1e-6 in the pointing, docs/physics.md §3). The window's rewards
hold to 1e-9; the last one holds the terminal pointing's ``-log10``, so its tolerance is the
pointing's relative one over ln 10 (under ``OPENBLAS_CORETYPE=Haswell`` the v1 episode of seed 3
ends 1.2e-9 from the record made under SkylakeX, a pointing 2.8e-9 apart).
"""

import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401

PATH = Path(__file__).parents[1] / "data" / "episodes_v0_2_0.json"
TASKS = ("LightSailRealistic-v0", "LightSail3DRealistic-v0", "LightSail3DRealistic-v1")
SEEDS = (3, 40)
#: Relative tolerance of the terminal pointing across BLAS kernels.
POINTING_RTOL = 1e-6


def play(env_id: str, seed: int) -> dict:
    """One episode of random actions (their generator seeded with ``seed`` too)."""
    env = gym.make(env_id)
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    out = {"seed": seed, "first_obs": obs.tolist(), "rewards": []}
    done = False
    while not done:
        action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        out["rewards"].append(float(reward))
        if len(out["rewards"]) == 7:
            out["obs_7"] = obs.tolist()
        done = terminated or truncated
    out.update(last_obs=obs.tolist(), pointing=float(info["terminal_pointing_rad"]),
               success=bool(info["is_success"]), diverged=bool(info["diverged"]))
    return out


REFERENCE = json.loads(PATH.read_text()) if PATH.exists() else {}


@pytest.mark.parametrize("env_id, seed", [(task, seed) for task in TASKS for seed in SEEDS])
def test_noisy_episodes_are_those_recorded(env_id, seed):
    recorded = next(e for e in REFERENCE[env_id] if e["seed"] == seed)
    played = play(env_id, seed)
    for key in ("first_obs", "obs_7", "last_obs"):
        np.testing.assert_allclose(played[key], recorded[key], rtol=1e-6, atol=1e-6, err_msg=key)
    np.testing.assert_allclose(played["rewards"][:-1], recorded["rewards"][:-1], rtol=0, atol=1e-9)
    assert played["rewards"][-1] == pytest.approx(recorded["rewards"][-1], rel=0, abs=POINTING_RTOL / math.log(10))
    assert played["pointing"] == pytest.approx(recorded["pointing"], rel=POINTING_RTOL)
    assert (played["success"], played["diverged"]) == (recorded["success"], recorded["diverged"])


if __name__ == "__main__":
    PATH.write_text(json.dumps({task: [play(task, seed) for seed in SEEDS] for task in TASKS}) + "\n")
    print(f"wrote {PATH}")
