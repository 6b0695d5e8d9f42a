"""Speed of the envs and of training, as ratios to Gymnasium's and SB3's own peers measured in the same run.

    python benchmarks/speed.py [--quick] [--out benchmarks/results/speed.json]

1. Single env step (``gym.make``, random actions, autoreset) against CartPole-v1 and Pendulum-v1.
2. Vector env-steps/s (``gym.make_vec(..., vectorization_mode="vector_entry_point")``) against
   ``CartPoleVectorEnv`` at N = 1, 64, 1024, 16384.
3. PPO training env-steps/s (the shipped LightSail-v0 configuration, no evaluation) with the
   batched adapter, SB3's DummyVecEnv and SubprocVecEnv, and the same configuration on Pendulum-v1.

One process, one BLAS and torch thread (as train.py runs). Prints markdown tables and writes JSON
with the machine and package versions.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import gymnasium as gym
from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv

import sail_env  # noqa: F401
from agents.sb3 import algo_kwargs, load_hyperparams, one_thread_per_process, versions
from agents.training import make_env
from sail_env.provenance import machine
from sail_env.tasks import TASKS


def single_rate(env_id: str, steps: int) -> float:
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def vector_rate(envs: gym.vector.VectorEnv, steps: int) -> float:
    envs.reset(seed=0)
    envs.action_space.seed(0)
    actions = [envs.action_space.sample() for _ in range(steps)]
    start = time.perf_counter()
    for action in actions:
        envs.step(action)
    return steps * envs.num_envs / (time.perf_counter() - start)


def ppo_rate(env_id: str, vec_env: str, steps: int) -> float:
    """Env-steps/s of PPO.learn with the shipped LightSail-v0 hyperparameters on ``env_id``."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    hp = load_hyperparams("ppo", "LightSail-v0")
    n_envs, policy = hp.pop("n_envs"), hp.pop("policy")
    hp.pop("n_timesteps"), hp.pop("normalize")
    if env_id in TASKS:
        env = make_env(env_id, n_envs, 0, vec_env, {}, hp["gamma"], training=True)
    else:  # a Gymnasium peer: SB3's own wrappers (no is_success to log)
        env = VecNormalize(make_vec_env(env_id, n_envs, seed=0), gamma=hp["gamma"])
    model = PPO(policy, env, seed=0, device="cpu", **algo_kwargs(hp, env.action_space.shape[0]))
    model.learn(2048)  # warm-up: first rollout and update
    start = time.perf_counter()
    model.learn(steps, reset_num_timesteps=False)
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps (a check that it runs, not a measurement)")
    parser.add_argument("--out", type=Path, default=Path("benchmarks/results/speed.json"))
    args = parser.parse_args()
    one_thread_per_process()
    single_steps, vector_steps, ppo_steps = (2_000, 20, 4_096) if args.quick else (40_000, 400, 40_960)
    result = {"machine": machine(),
              "versions": versions(), "single": {}, "vector": {}, "ppo": {}}

    peers = {name: single_rate(name, single_steps) for name in ("CartPole-v1", "Pendulum-v1")}
    print("| env (single, gym.make) | steps/s | × CartPole-v1 | × Pendulum-v1 |\n|---|---:|---:|---:|")
    for env_id in [*peers, *TASKS]:
        rate = peers.get(env_id) or single_rate(env_id, single_steps)
        result["single"][env_id] = rate
        print(f"| {env_id} | {rate:,.0f} | {rate / peers['CartPole-v1']:.2f} | {rate / peers['Pendulum-v1']:.2f} |")

    print("\n| N | CartPoleVectorEnv env-steps/s | " + " | ".join(f"{e} (×)" for e in TASKS) + " |")
    print("|---:|---:|" + "---:|" * len(TASKS))
    for n in (1, 64, 1024, 16384):
        steps = max(10, vector_steps // (16 if n == 16384 else 1))
        reference = vector_rate(CartPoleVectorEnv(num_envs=n), steps)
        rates = {e: vector_rate(gym.make_vec(e, num_envs=n, vectorization_mode="vector_entry_point"), steps)
                 for e in TASKS}
        result["vector"][n] = {"CartPoleVectorEnv": reference, **rates}
        print(f"| {n} | {reference:,.0f} | " + " | ".join(f"{r:,.0f} ({r / reference:.2f})" for r in rates.values()) + " |")

    print("\n| PPO (shipped LightSail-v0 config, 8 envs) | env-steps/s | × Pendulum-v1 |\n|---|---:|---:|")
    pendulum = ppo_rate("Pendulum-v1", "dummy", ppo_steps)
    for label, env_id, vec_env in (("Pendulum-v1, DummyVecEnv", "Pendulum-v1", None),
                                   ("LightSail-v0, batched adapter", "LightSail-v0", "batched"),
                                   ("LightSail-v0, DummyVecEnv", "LightSail-v0", "dummy"),
                                   ("LightSail-v0, SubprocVecEnv", "LightSail-v0", "subproc")):
        rate = pendulum if vec_env is None else ppo_rate(env_id, vec_env, ppo_steps)
        result["ppo"][label] = rate
        print(f"| {label} | {rate:,.0f} | {rate / pendulum:.2f} |")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
