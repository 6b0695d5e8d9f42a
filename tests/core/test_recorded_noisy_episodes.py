"""The noisy tasks against episodes recorded with lightsail-gym 0.2.0 (tests/data/episodes_v0_2_0.json),
and the uncertain task against episodes recorded with 0.5.0 (tests/data/episodes_v0_5_0.json) played by
``lqg-mm-offset``: random actions end its episodes in the window, and its record pins each draw's own
sail through the coast too, beyond the diffraction length where the spot widens.

The episodes draw every disturbance (sensor noise, jitter, push noise, dust, parameter spread,
cut-off time, the coast's end state), so they pin the sampler and the order of the draws: a change
that alters them is a new env version. Regenerate one record (only with a new version):
``python tests/core/test_recorded_noisy_episodes.py v0.5.0``.

**Tolerances: the spread across BLAS kernels, measured.** The same machine and kernel reproduce the
records to the last bit. Another OpenBLAS kernel (another CPU, or ``OPENBLAS_CORETYPE``) rounds the
last bits of a matrix product differently: each draw's model and the coast's exponentials move by
round-off, which the coast's ~40,000 rad of phase amplifies in the pointing. A feedback agent adds the
observation's float32 rounding: a state 1e-11 apart now and then rounds to the neighbouring float32,
the agent acts on it, and the rest of the episode moves by that much (docs/physics.md §3). So each
record is held to its own measured spread (:data:`TOLERANCES`, from ``python -m benchmarks.cross_kernel``
over 200 episodes and from the records under five kernels, docs/development.md "Same numbers across
machines"), with a margin; a change of the draws moves these numbers by orders of magnitude more.
:func:`test_the_records_hold_under_another_kernel` plays the records again under a second kernel.
"""

import json
import math
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import gymnasium as gym
import numpy as np
import pytest
from threadpoolctl import threadpool_info

import sail_env  # noqa: F401
from agents.evaluation import BASELINES

DATA = Path(__file__).parents[1] / "data"


class Tolerance(NamedTuple):
    """How far a record's episode may be played from it under another BLAS kernel."""

    window_reward: float  # absolute, each reward of the window
    pointing: float  # relative, the terminal pointing (the last reward holds its -log10: this over ln 10)


#: Open loop (random actions): across SkylakeX, Haswell, Zen, Sandybridge and Prescott the records' 6
#: episodes moved by at most 2.3e-12 in a window reward and 6.7e-9 in the pointing; 200 passive episodes
#: a task (SkylakeX against Haswell) by at most 3.2e-11 and 1.4e-7 (docs/development.md).
OPEN_LOOP = Tolerance(window_reward=1e-9, pointing=1e-6)
#: ``lqg-mm-offset`` on the uncertain task (feedback through float32 observations): the records' 2
#: episodes moved by up to 1.0e-8 in a window reward and 3.4e-7 in the pointing across those kernels;
#: 200 episodes (SkylakeX against Haswell) by up to 4.7e-8 and 1.2e-5 (docs/development.md).
FEEDBACK = Tolerance(window_reward=5e-7, pointing=1e-4)
#: Each record: its file, its tasks, the agent that played them (None: uniform random actions), its tolerance.
RECORDS = {"v0.2.0": (DATA / "episodes_v0_2_0.json",
                      ("LightSailRealistic-v0", "LightSail3DRealistic-v0", "LightSail3DRealistic-v1"), None, OPEN_LOOP),
           "v0.5.0": (DATA / "episodes_v0_5_0.json", ("LightSailUncertain-v2",), "lqg-mm-offset", FEEDBACK)}
SEEDS = (3, 40)
#: OpenBLAS x86-64 kernels a second run can take, with the CPU flag each needs (Prescott: any x86-64).
KERNELS = (("SkylakeX", "avx512f"), ("Haswell", "avx2"), ("Prescott", None))


def play(env_id: str, seed: int, agent_name: str | None = None) -> dict:
    """One episode of the agent's actions, or of random actions (their generator seeded with ``seed`` too)."""
    env = gym.make(env_id)
    rng = np.random.default_rng(seed)
    agent = BASELINES[agent_name](env.unwrapped.episode_spec) if agent_name else None
    obs, _ = env.reset(seed=seed)
    out = {"seed": seed, "first_obs": obs.tolist(), "rewards": []}
    done = False
    while not done:
        action = agent.act(obs) if agent else rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        out["rewards"].append(float(reward))
        if len(out["rewards"]) == 7:
            out["obs_7"] = obs.tolist()
        done = terminated or truncated
    out.update(last_obs=obs.tolist(), pointing=float(info["terminal_pointing_rad"]),
               success=bool(info["is_success"]), diverged=bool(info["diverged"]))
    return out


@pytest.mark.parametrize("version, env_id, seed", [(version, task, seed) for version, (_, tasks, _, _) in RECORDS.items()
                                                   for task in tasks for seed in SEEDS])
def test_noisy_episodes_are_those_recorded(version, env_id, seed):
    path, _, agent, tolerance = RECORDS[version]
    recorded = next(e for e in json.loads(path.read_text())[env_id] if e["seed"] == seed)
    played = play(env_id, seed, agent)
    for key in ("first_obs", "obs_7", "last_obs"):  # float32: one rounding apart at most
        np.testing.assert_allclose(played[key], recorded[key], rtol=1e-6, atol=1e-6, err_msg=key)
    np.testing.assert_allclose(played["rewards"][:-1], recorded["rewards"][:-1], rtol=0, atol=tolerance.window_reward)
    assert played["rewards"][-1] == pytest.approx(recorded["rewards"][-1], rel=0,
                                                  abs=tolerance.pointing / math.log(10) + tolerance.window_reward)
    assert played["pointing"] == pytest.approx(recorded["pointing"], rel=tolerance.pointing)
    assert (played["success"], played["diverged"]) == (recorded["success"], recorded["diverged"])


def blas_kernel(env: dict[str, str] | None = None) -> str | None:
    """The OpenBLAS kernel numpy runs under ``env`` (None: this process's), None without OpenBLAS."""
    if env is None:
        kernels = [i.get("architecture") for i in threadpool_info() if i["internal_api"] == "openblas"]
        return kernels[0] if kernels else None
    code = ("import numpy, threadpoolctl; print(next((i.get('architecture') for i in threadpoolctl.threadpool_info() "
            "if i['internal_api'] == 'openblas'), None))")
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          check=True).stdout.strip()


def another_kernel(current: str) -> str:
    """The first of :data:`KERNELS` that is not ``current`` and that this CPU runs."""
    flags = set()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.is_file():
        flags = set(next((line.split(":", 1)[1].split() for line in cpuinfo.read_text().splitlines()
                          if line.startswith("flags")), []))
    return next(name for name, flag in KERNELS if name.lower() != current.lower() and (flag is None or flag in flags))


@pytest.mark.slow
def test_the_records_hold_under_another_kernel():
    """This module's records, played again in a child process under a second OpenBLAS kernel (SkylakeX
    and Haswell, the two that a machine with and one without ``OPENBLAS_CORETYPE=Haswell`` runs on an
    AVX-512 CPU; Prescott where neither differs or runs): the next drift is caught on any machine."""
    current = blas_kernel()
    if current is None or platform.machine() not in ("x86_64", "AMD64"):
        pytest.skip(f"numpy's BLAS is not OpenBLAS on x86-64 (kernel {current}, machine {platform.machine()})")
    other = another_kernel(current)
    env = {key: value for key, value in os.environ.items() if key != "OPENBLAS_L2_SIZE"}
    env["OPENBLAS_CORETYPE"] = other
    assert blas_kernel(env).lower() == other.lower(), f"OPENBLAS_CORETYPE={other} did not take"
    child = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"{__file__}::"
                            "test_noisy_episodes_are_those_recorded"], env=env, capture_output=True, text=True,
                           cwd=Path(__file__).parents[2])
    assert child.returncode == 0, f"under {other} (this process: {current}):\n{child.stdout[-3000:]}"


if __name__ == "__main__":  # python tests/core/test_recorded_noisy_episodes.py v0.5.0: that record, anew
    path, tasks, agent, _ = RECORDS[sys.argv[1]]
    path.write_text(json.dumps({task: [play(task, seed, agent) for seed in SEEDS] for task in tasks}) + "\n")
    print(f"wrote {path}")
