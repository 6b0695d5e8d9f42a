"""A first try with a standard PPO: what its training curve measures on LightSail-v0 (issue 19).

A single-file PPO in the style of CleanRL's ``ppo_continuous_action.py`` (its defaults: 2048
steps per env and update, 10 epochs of 32 minibatches, a state-independent log-std starting at 0;
but 4 envs, as in issue 19's run, and an unclipped value loss) behind Gymnasium's standard
wrappers (ClipAction, NormalizeObservation + clip, NormalizeReward + clip). After training it plays fresh episodes, seeded apart from training,
twice: with the mean action (deterministic, how the project scores a learner) and with actions
sampled as in training (stochastic). The training-time return of the last 200 episodes is the
curve such a user looks at; it is the stochastic policy's, so with the initial std of 1 (the
whole action range) it measures the exploration noise, not the policy.

    python -m research.first_try --seeds 1 2 3                       # CleanRL defaults
    python -m research.first_try --seeds 1 2 3 --log-std-init -2     # a smaller initial std
    python -m research.first_try --noise-table                       # LQR + Gaussian action noise

Each run prints one JSON line and appends it to ``research/results/first_try.jsonl``
(``--out``); the noise table prints one line per σ and appends one JSON line for the table.
Results and the diagnosis: docs/learners.md, "A first try with a standard PPO".
"""

from __future__ import annotations

import argparse
import datetime
import json
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
import torch.nn as nn
from torch.distributions import Normal

import sail_env  # noqa: F401  (registers the ids)
from agents import LQRAgent

RESULTS = Path(__file__).parent / "results" / "first_try.jsonl"
EVAL_SEED = 100_000  # evaluation episodes: seeds EVAL_SEED + i, far from training's
NOISE_SIGMAS = (0.0, 0.05, 0.1, 0.2, 0.37, 0.5, 0.9, 1.0)


def make_env(env_id: str, args: argparse.Namespace):
    """One training env with Gymnasium's standard wrappers, as CleanRL builds it."""
    def thunk() -> gym.Env:
        env = gym.make(env_id)
        env = gym.wrappers.FlattenObservation(env)
        env = gym.wrappers.RecordEpisodeStatistics(env)
        env = gym.wrappers.ClipAction(env)
        if args.zero_obs is not None:  # an ablation: hide one observation component
            keep = np.ones(env.observation_space.shape, dtype=np.float32)
            keep[args.zero_obs] = 0.0
            env = gym.wrappers.TransformObservation(env, lambda o: o * keep, env.observation_space)
        if args.norm_obs:
            env = gym.wrappers.NormalizeObservation(env)
            env = gym.wrappers.TransformObservation(env, lambda o: np.clip(o, -10, 10), env.observation_space)
        if args.norm_reward:
            env = gym.wrappers.NormalizeReward(env, gamma=args.gamma)
            env = gym.wrappers.TransformReward(env, lambda r: float(np.clip(r, -10, 10)))
        return env
    return thunk


def layer(n_in: int, n_out: int, std: float = np.sqrt(2)) -> nn.Linear:
    linear = nn.Linear(n_in, n_out)
    nn.init.orthogonal_(linear.weight, std)
    nn.init.zeros_(linear.bias)
    return linear


class ActorCritic(nn.Module):
    def __init__(self, obs_dim: int, act_dim: int, log_std_init: float) -> None:
        super().__init__()
        self.critic = nn.Sequential(layer(obs_dim, 64), nn.Tanh(), layer(64, 64), nn.Tanh(), layer(64, 1, 1.0))
        self.actor_mean = nn.Sequential(layer(obs_dim, 64), nn.Tanh(), layer(64, 64), nn.Tanh(),
                                        layer(64, act_dim, 0.01))
        self.log_std = nn.Parameter(torch.full((1, act_dim), log_std_init))

    def dist(self, x: torch.Tensor) -> Normal:
        mean = self.actor_mean(x)
        return Normal(mean, self.log_std.expand_as(mean).exp())

    def value(self, x: torch.Tensor) -> torch.Tensor:
        return self.critic(x).squeeze(-1)


def find_wrapper(env: gym.Env, kind: type) -> gym.Wrapper | None:
    while isinstance(env, gym.Wrapper):
        if isinstance(env, kind):
            return env
        env = env.env
    return None


def train(args: argparse.Namespace, seed: int) -> dict:
    """Train one seed, evaluate it, return the JSON row."""
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    envs = gym.vector.SyncVectorEnv([make_env(args.env, args) for _ in range(args.num_envs)],
                                    autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
    obs_dim = envs.single_observation_space.shape[0]
    act_dim = envs.single_action_space.shape[0]
    agent = ActorCritic(obs_dim, act_dim, args.log_std_init)
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.lr, eps=1e-5)

    n_envs, n_steps = args.num_envs, args.num_steps
    batch_size = n_envs * n_steps
    minibatch = batch_size // args.minibatches
    iterations = args.total_steps // batch_size
    obs_buf = torch.zeros(n_steps, n_envs, obs_dim)
    act_buf = torch.zeros(n_steps, n_envs, act_dim)
    logp_buf, rew_buf, done_buf, val_buf = (torch.zeros(n_steps, n_envs) for _ in range(4))

    start = time.time()
    obs = torch.tensor(envs.reset(seed=seed)[0], dtype=torch.float32)
    returns, successes, steps = [], [], 0
    for iteration in range(iterations):
        optimizer.param_groups[0]["lr"] = args.lr * (1 - iteration / iterations)  # annealed, as CleanRL
        for t in range(n_steps):
            obs_buf[t] = obs
            with torch.no_grad():
                dist = agent.dist(obs)
                action = dist.sample()
                logp_buf[t] = dist.log_prob(action).sum(1)
                val_buf[t] = agent.value(obs)
            act_buf[t] = action
            next_obs, reward, terminated, truncated, info = envs.step(action.numpy())
            steps += n_envs
            done = np.logical_or(terminated, truncated)
            rew_buf[t] = torch.tensor(reward, dtype=torch.float32)
            done_buf[t] = torch.tensor(done, dtype=torch.float32)
            obs = torch.tensor(next_obs, dtype=torch.float32)
            for i in np.nonzero(done)[0]:  # SAME_STEP autoreset: the finished episode is in final_info
                returns.append(float(info["final_info"]["episode"]["r"][i]))
                successes.append(bool(info["final_info"]["is_success"][i]))

        # GAE. Episodes end by termination only (the end of the window or divergence), so a done
        # step is not bootstrapped; with SAME_STEP autoreset `obs` after it is already the next episode's.
        with torch.no_grad():
            next_value = agent.value(obs)
            advantages = torch.zeros(n_steps, n_envs)
            last = torch.zeros(n_envs)
            for t in reversed(range(n_steps)):
                following = next_value if t == n_steps - 1 else val_buf[t + 1]
                alive = 1.0 - done_buf[t]
                delta = rew_buf[t] + args.gamma * following * alive - val_buf[t]
                last = delta + args.gamma * args.gae_lambda * alive * last
                advantages[t] = last
            targets = advantages + val_buf

        b_obs, b_act = obs_buf.reshape(-1, obs_dim), act_buf.reshape(-1, act_dim)
        b_logp, b_adv, b_ret = logp_buf.reshape(-1), advantages.reshape(-1), targets.reshape(-1)
        for _ in range(args.epochs):
            order = rng.permutation(batch_size)
            for begin in range(0, batch_size, minibatch):
                j = order[begin:begin + minibatch]
                dist = agent.dist(b_obs[j])
                ratio = (dist.log_prob(b_act[j]).sum(1) - b_logp[j]).exp()
                adv = (b_adv[j] - b_adv[j].mean()) / (b_adv[j].std() + 1e-8)
                policy_loss = torch.max(-adv * ratio, -adv * ratio.clamp(1 - args.clip, 1 + args.clip)).mean()
                value_loss = 0.5 * ((agent.value(b_obs[j]) - b_ret[j]) ** 2).mean()
                loss = policy_loss + args.vf_coef * value_loss
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
                optimizer.step()

    # Evaluate on fresh episodes: the observation statistics of env 0 frozen, the raw reward.
    normalizer = find_wrapper(envs.envs[0], gym.wrappers.NormalizeObservation)
    obs_rms = normalizer.obs_rms if normalizer is not None else None
    keep = np.ones(obs_dim)
    if args.zero_obs is not None:
        keep[args.zero_obs] = 0.0
    noise = torch.Generator().manual_seed(seed)

    def policy(o: np.ndarray, stochastic: bool) -> np.ndarray:
        x = o.astype(np.float64) * keep
        if obs_rms is not None:
            x = np.clip((x - obs_rms.mean) / np.sqrt(obs_rms.var + normalizer.epsilon), -10, 10)
        with torch.no_grad():
            mean = agent.actor_mean(torch.tensor(x, dtype=torch.float32)[None])[0]
            if stochastic:
                mean = mean + agent.log_std[0].exp() * torch.randn(mean.shape, generator=noise)
        return np.clip(mean.numpy(), -1, 1)  # as ClipAction does

    deterministic = play(args.env, lambda o: policy(o, False), args.eval_episodes)
    stochastic = play(args.env, lambda o: policy(o, True), args.eval_episodes)
    return dict(
        env=args.env, seed=seed, steps=steps, log_std_init=args.log_std_init, norm_obs=args.norm_obs,
        norm_reward=args.norm_reward, gamma=args.gamma, zero_obs=args.zero_obs, eval_episodes=args.eval_episodes,
        det_success=deterministic["success"], det_return=deterministic["return"],
        sto_success=stochastic["success"], sto_return=stochastic["return"],
        train_last200_return=round(float(np.mean(returns[-200:])), 4) if returns else None,
        train_last200_success=round(float(np.mean(successes[-200:])), 4) if returns else None,
        final_action_std=[round(s, 4) for s in agent.log_std.exp()[0].tolist()],
        obs_rms_std=None if obs_rms is None else np.sqrt(obs_rms.var).round(6).tolist(),
        wall_s=round(time.time() - start, 1), date=datetime.date.today().isoformat())


def play(env_id: str, policy, episodes: int) -> dict:
    """Success rate and mean return of ``policy`` on the episodes seeded EVAL_SEED, EVAL_SEED + 1, ..."""
    env = gym.make(env_id)
    success, total = [], []
    for episode in range(episodes):
        obs, _ = env.reset(seed=EVAL_SEED + episode)
        done, episode_return = False, 0.0
        while not done:
            obs, reward, terminated, truncated, info = env.step(np.asarray(policy(obs), dtype=np.float32))
            episode_return += reward
            done = terminated or truncated
        success.append(bool(info["is_success"]))
        total.append(episode_return)
    return {"success": float(np.mean(success)), "return": round(float(np.mean(total)), 4)}


def noise_table(env_id: str, sigmas=NOISE_SIGMAS, episodes: int = 100, seed: int = 0) -> list[dict]:
    """The LQR with Gaussian noise of std σ added to its action (then clipped to [-1, 1])."""
    spec = gym.make(env_id).unwrapped.episode_spec
    rows = []
    for sigma in sigmas:
        lqr, rng = LQRAgent(spec), np.random.default_rng(seed)
        result = play(env_id, lambda o: np.clip(lqr.act(o) + sigma * rng.standard_normal(2), -1, 1), episodes)
        rows.append({"sigma": sigma, **result})
    return rows


def main(argv: list[str] | None = None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="LightSail-v0")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--total-steps", type=int, default=150_000)
    parser.add_argument("--num-envs", type=int, default=4)
    parser.add_argument("--num-steps", type=int, default=2048, help="steps per env and update")
    parser.add_argument("--lr", type=float, default=3e-4)
    parser.add_argument("--epochs", type=int, default=10)
    parser.add_argument("--minibatches", type=int, default=32)
    parser.add_argument("--gamma", type=float, default=0.99)
    parser.add_argument("--gae-lambda", type=float, default=0.95)
    parser.add_argument("--clip", type=float, default=0.2)
    parser.add_argument("--vf-coef", type=float, default=0.5)
    parser.add_argument("--max-grad-norm", type=float, default=0.5)
    parser.add_argument("--log-std-init", type=float, default=0.0, help="CleanRL: 0 (std 1, the action range)")
    parser.add_argument("--no-norm-obs", dest="norm_obs", action="store_false", help="no NormalizeObservation")
    parser.add_argument("--no-norm-reward", dest="norm_reward", action="store_false", help="no NormalizeReward")
    parser.add_argument("--zero-obs", type=int, default=None, help="set this observation component to 0")
    parser.add_argument("--eval-episodes", type=int, default=100)
    parser.add_argument("--noise-table", action="store_true", help="print the LQR + action-noise table instead")
    parser.add_argument("--out", type=Path, default=RESULTS, help="JSON lines appended here ('-': none)")
    args = parser.parse_args(argv)
    torch.set_num_threads(1)

    if args.noise_table:
        rows = noise_table(args.env, episodes=args.eval_episodes)
        for row in rows:
            print(f"sigma {row['sigma']:4.2f}: success {row['success']:.2f}, return {row['return']:+.3f}")
        results = [{"noise_table": args.env, "episodes": args.eval_episodes, "rows": rows,
                    "date": datetime.date.today().isoformat()}]
        record(results[0], args.out)
        return results
    results = []
    for seed in args.seeds:
        results.append(train(args, seed))
        print(json.dumps(results[-1]), flush=True)
        record(results[-1], args.out)
    return results


def record(row: dict, out: Path) -> None:
    if str(out) != "-":
        with out.open("a") as file:
            file.write(json.dumps(row) + "\n")

if __name__ == "__main__":
    main()
