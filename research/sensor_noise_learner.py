"""Is the uncertain task's learner limited by the sensor noise it must filter? Train it without (or with less).

    python -m research.sensor_noise_learner --scale 0 --out research/results/sensor_noise_learner.json -- \\
        -n 10000000 --num-envs 256 --num-steps 64 --num-minibatches 32 --learning-rate 1e-4 \\
        --final-learning-rate 1e-5 --hidden 256,256 --history 8 --episode-mean --clipped-likelihood \\
        --tanh-mean --log-std-init -2 --state-dependent-std

The flags after ``--`` are ``train_jax.py``'s (its PPO settings; one seed, ``--first-seed``). The run trains
on ``LightSailUncertain-v2`` with its sensor noise's standard deviations times ``--scale`` (the task's
own ``sensor_noise_std`` keyword; everything else as the task), in chunks of ``--chunk`` updates, and after
each writes the curve (the deterministic policy's success on 256 fresh episodes of that env, the
episodes of ``train_jax.py``'s curve) to ``--out``, replaced whole. At the end it scores the final
policy on ``--final-episodes`` fresh episodes of that env and of the task as it is (1,000 by default: ``train_jax.py``'s
final episodes).

A policy that sees 8 noisy observations and their episode's mean estimates the sail's state less
precisely than a Kalman filter over the whole episode (the bank's): if that is what holds the learner
at ~80 %, the same recipe without sensor noise should score near the bank (94.5 %); if it stops where it
does with the noise, the limit is elsewhere. With ``--first-seed 0`` and the settings above the run
draws as ``train_jax.py``'s seed 0 (the same keys; the sensor noise's normals drawn and scaled to zero),
so its curve compares point by point with that run's. Its numbers are in docs/learners.md ("Averaged
actors, and a GRU with the recipe (eighth points)"). No checkpoint: one seed over 10M steps takes ~40
minutes alone on a core of this CPU; an interrupted run starts again, and its curve so far stays in ``--out``.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import sys
import time
from pathlib import Path

import jax
import numpy as np

import sail_env.jax
import train_jax
from agents import cli
from agents.jax_ppo import PPOConfig, make_chunks, play_deterministic
from sail_env.jax.env import EnvParams
from sail_env.tasks import RIGID3D_TASKS

ENV_ID = "LightSailUncertain-v2"


def with_sensor_noise(scale: float) -> EnvParams:
    """The task's params with its declared sensor noise's standard deviations times ``scale``."""
    declared = RIGID3D_TASKS[ENV_ID]["sensor_noise_std"]
    return sail_env.jax.make(ENV_ID, sensor_noise_std=tuple(scale * std for std in declared))[1]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    ours, ppo_flags = (argv[:argv.index("--")], argv[argv.index("--") + 1:]) if "--" in argv else (argv, [])
    parser = cli.Parser(prog="python -m research.sensor_noise_learner", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter)
    parser.add_argument("--scale", type=float, required=True, help="the sensor noise's factor, >= 0 (1: the task's)")
    parser.add_argument("--chunk", type=cli.positive_int, default=24, help="updates between curve points")
    parser.add_argument("--final-episodes", type=cli.positive_int, default=train_jax.EVAL_EPISODES,
                        help="fresh episodes the final policy is scored on, on each env")
    parser.add_argument("--out", type=Path, required=True, help="the results' JSON file (a new one)")
    try:
        args = parser.parse_args(ours)
        ppo_parser = train_jax.build_parser()
        ppo = ppo_parser.parse_args(ppo_flags)
        # Only PPO's settings and the seed apply here: any other flag of train_jax.py is refused, not ignored.
        applies = {field.name for field in dataclasses.fields(PPOConfig)} | {"first_seed"}
        ignored = [name for name, value in vars(ppo).items()
                   if name not in applies and value != ppo_parser.get_default(name)]
        if ignored:
            raise cli.UsageError(f"{train_jax.flag_of(ppo_parser, ignored[0])}: only train_jax.py's PPO settings "
                                 f"and --first-seed apply here (the task is {ENV_ID}, one seed, no run folder)")
        config = train_jax.config_of(vars(ppo))
        if not args.scale >= 0:
            raise cli.UsageError(f"--scale must be >= 0, got {args.scale}")
        if args.out.exists():
            raise cli.UsageError(f"--out {args.out}: exists; results are not overwritten")
    except (cli.UsageError, ValueError) as err:
        return cli.fail(err)

    env, task = sail_env.jax.make(ENV_ID)
    scaled = with_sensor_noise(args.scale)
    chunks = make_chunks(env, scaled, config)
    run = jax.jit(chunks.run, static_argnums=1)

    @functools.partial(jax.jit, static_argnames="episodes")
    def score(actor, params, key, episodes):
        return play_deterministic(env, params, config, actor, key, episodes)[0]

    record = {"env_id": ENV_ID, "sensor_noise_scale": args.scale, "seed": ppo.first_seed,
              "config": {k: list(v) if isinstance(v, tuple) else v for k, v in vars(config).items()},
              "curve": [], "status": "running"}
    state, start = jax.jit(chunks.init)(jax.random.key(ppo.first_seed)), time.perf_counter()
    updates = 0
    while updates < config.num_updates:
        step = min(args.chunk, config.num_updates - updates)
        state, _ = run(state, step)
        updates += step
        rate = float(score(state.network["actor"], scaled, jax.random.key(train_jax.CURVE_KEY),
                           train_jax.CURVE_EPISODES))
        record["curve"].append([updates * config.batch_size, rate])
        record["wall_s"] = time.perf_counter() - start
        cli.write_whole(args.out, json.dumps(record, indent=1))
        print(f"{updates * config.batch_size:,} steps: {rate:.1%} on {train_jax.CURVE_EPISODES} episodes", flush=True)
    key = jax.random.key(train_jax.EVAL_KEY)
    for name, params in (("final_success_scaled_noise", scaled), ("final_success_task", task)):
        record[name] = float(score(state.network["actor"], params, key, args.final_episodes))
    record["status"], record["wall_s"] = "finished", time.perf_counter() - start
    cli.write_whole(args.out, json.dumps(record, indent=1))
    print(f"final policy on {args.final_episodes:,} episodes: {record['final_success_scaled_noise']:.1%} with "
          f"the noise times {args.scale}, {record['final_success_task']:.1%} on the task")
    return 0


if __name__ == "__main__":
    sys.exit(main())
