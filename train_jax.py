"""Train PPO on the JAX backend, many seeds in one jitted run: ``python train_jax.py --env LightSail-v0 --seeds 16``.

The whole loop (rollouts, GAE, minibatch epochs) is one compiled function of a key
(:mod:`agents.jax_ppo`), ``vmap``-ed over the seeds. Each seed gets a run folder as ``train.py``'s,
``runs/<env>-jax_ppo-<seed>`` (``_2``, ``_3``, … if taken; ``runs/latest`` then names the first
seed's), holding ``policy.npz`` (the deterministic actor, which ``evaluate.py --agent
runs/latest/policy.npz`` plays on the Gym env) and ``run.json`` (the settings, the device, the
wall time with compilation, the success rate of each rollout's ended episodes, and the
deterministic policy's success on 1,000 fresh episodes of the JAX env). Nothing is written
before the run has finished; a refused argument is one line on stderr and exit 2.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

import jax
import numpy as np

import sail_env.jax
from agents import cli
from agents.jax_ppo import PPOConfig, actor_arrays, make_train, success_rate
from agents.mlp_policy import POLICY_FILE, save_policy
from agents.training import new_run_dir, point_latest
from sail_env.tasks import JAX_TASKS

ALGO = "jax_ppo"


def parse_args(argv: list[str] | None):
    defaults = {f.name: f.default for f in dataclasses.fields(PPOConfig)}
    parser = cli.Parser(description=cli.describe(__doc__), formatter_class=cli.HelpFormatter)
    parser.add_argument("--env", default="LightSail-v0", help="a task of the JAX backend (sail_env.tasks.JAX_TASKS)")
    parser.add_argument("--seeds", type=cli.positive_int, default=1, help="how many seeds, trained together")
    parser.add_argument("--first-seed", type=cli.non_negative_int, default=0, help="the first seed's number")
    parser.add_argument("-n", "--timesteps", type=cli.positive_int, default=defaults["total_timesteps"],
                        help="env steps per seed")
    parser.add_argument("--num-envs", type=cli.positive_int, default=defaults["num_envs"])
    parser.add_argument("--num-steps", type=cli.positive_int, default=defaults["num_steps"],
                        help="steps per environment per rollout")
    parser.add_argument("--learning-rate", type=float, default=defaults["learning_rate"])
    parser.add_argument("--runs-dir", type=Path, default=Path("runs"))
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    try:
        args = parse_args(argv)
        if args.env not in JAX_TASKS:
            raise cli.UsageError(f"--env {args.env}: the JAX backend has {', '.join(JAX_TASKS)}")
        config = PPOConfig(total_timesteps=args.timesteps, num_envs=args.num_envs, num_steps=args.num_steps,
                           learning_rate=args.learning_rate)
        cli.check_writable_dir(args.runs_dir, "--runs-dir")
    except (cli.UsageError, ValueError) as err:
        return cli.fail(err)

    env, params = sail_env.jax.make(args.env)
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    device = jax.devices()[0]
    print(f"{ALGO} on {args.env}: {config.num_updates * config.batch_size:,} steps x {len(seeds)} seeds "
          f"({config.num_envs} envs) on {device.device_kind}", flush=True)
    start = time.perf_counter()
    train = jax.jit(jax.vmap(make_train(env, params, config)))
    out = jax.block_until_ready(train(jax.vmap(jax.random.key)(np.array(seeds))))
    wall = time.perf_counter() - start
    evaluate = jax.jit(jax.vmap(lambda actor: success_rate(env, params, config, actor, jax.random.key(10**6), 1000)))
    final = np.asarray(evaluate(out["network"]["actor"]))
    curve = np.asarray(out["metrics"]["success"])
    runs = []
    for row, seed in enumerate(seeds):
        run_dir = new_run_dir(args.env, ALGO, seed, args.runs_dir)
        network = jax.tree.map(lambda a: np.asarray(a)[row], out["network"])
        save_policy(run_dir / POLICY_FILE, actor_arrays(network),
                    {"env_id": args.env, "algo": ALGO, "seed": seed, "timesteps": config.num_updates * config.batch_size,
                     "history": config.history, "recurrent": config.recurrent})
        record = {"env_id": args.env, "algo": ALGO, "seed": seed, "seeds_trained_together": len(seeds),
                  "config": dataclasses.asdict(config), "device": str(device.device_kind), "jax": jax.__version__,
                  "wall_s_with_compile": wall, "success_per_update": [None if np.isnan(v) else float(v) for v in curve[row]],
                  "steps_per_update": config.batch_size, "final_success_jax_1000": float(final[row]),
                  "command": " ".join(["python", "train_jax.py", *(sys.argv[1:] if argv is None else argv)])}
        temporary = run_dir / ".run.json.partial"
        temporary.write_text(json.dumps(record, indent=1))
        temporary.replace(run_dir / "run.json")
        runs.append(run_dir)
        print(f"seed {seed}: {float(final[row]):.1%} success on 1,000 JAX episodes -> {run_dir / POLICY_FILE}")
    point_latest(runs[0])
    print(f"finished: {len(seeds)} seeds in {wall:.1f} s with compilation "
          f"({len(seeds) * config.num_updates * config.batch_size / wall:,.0f} env-steps/s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
