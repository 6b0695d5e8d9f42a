"""How fast ``train_jax.py`` trains a recipe on the fast coast against the default coast: env steps per second of
whole PPO updates, in one process, interleaved (default, fast, …; best of ``--rounds``). A timed call makes as
many updates as cover a whole number of episode windows (the envs' episodes end together, so a call of fewer
updates would time coasts in proportion to where it starts, or none).

    env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE taskset -c 0 python -m benchmarks.speed_train_jax \\
        --rounds 1 --out benchmarks/results/speed_train_jax.json -- <train_jax.py's recipe flags>

The flags after ``--`` are ``train_jax.py``'s (the README's uncertain recipe, say; ``--draws`` sizes both
coasts' banks, else each plays its own: the default coast 4,096 draws, the fast one 512); ``--coast``, ``--terminal-reward`` and ``-n`` among
them are ignored (the coasts are what is compared; the annealing's length
does not change an update's cost). Each coast's programs are compiled before the first timed round.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import jax
import numpy as np

import train_jax
from agents import cli
from benchmarks.speed_jax import timed
from sail_env.provenance import machine

COASTS = ("default", "fast")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    own, recipe = (argv[:argv.index("--")], argv[argv.index("--") + 1:]) if "--" in argv else (argv, [])
    parser = cli.Parser(prog="python -m benchmarks.speed_train_jax", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter)
    parser.add_argument("--updates", type=cli.positive_int,
                        help="PPO updates per timed call (default: those of a whole number of episode windows)")
    parser.add_argument("--rounds", type=cli.positive_int, default=2)
    parser.add_argument("--out", type=Path, help="the result as JSON")
    args = parser.parse_args(own)
    try:
        flags = train_jax.build_parser().parse_args(recipe)
    except SystemExit:
        return 2
    config = train_jax.config_of(vars(flags))
    keys = train_jax.seed_keys([0])
    subjects = {}
    for coast in COASTS:
        options = train_jax.env_options(coast, None, "sampled", flags.draws)
        begin = time.perf_counter()
        try:
            env, params = train_jax.task(flags.env, options)
        except ValueError as err:
            return cli.fail(cli.UsageError(f"--env {flags.env}: {err}"))
        build_s = time.perf_counter() - begin
        updates = args.updates or math.lcm(config.num_steps, params.max_steps_in_episode) // config.num_steps
        state = train_jax.init_states(keys, flags.env, config, options, params)

        # The params enter as an argument, as in train_jax.py (the fast coast's maps as constants: copies).
        def update(state, params, options=options, updates=updates):
            return train_jax.run_chunk(state, flags.env, config, updates, options, params)

        compile_s = timed(update, state, params)  # the first call compiles
        subjects[coast] = {"update": update, "state": state, "params": params, "updates": updates,
                           "build_s": build_s, "first_call_s": compile_s, "update_s": np.inf}
    for _ in range(args.rounds):
        for s in subjects.values():
            s["update_s"] = min(s["update_s"], timed(s["update"], s["state"], s["params"]))
    rows = [{"coast": coast, "updates": s["updates"], "env_steps_per_s": s["updates"] * config.batch_size / s["update_s"],
             "build_s": s["build_s"], "first_call_s": s["first_call_s"]} for coast, s in subjects.items()]
    ratio = rows[1]["env_steps_per_s"] / rows[0]["env_steps_per_s"]
    print("| coast | updates a call | env-steps/s (whole updates) | build [s] |")
    print("|---|---:|---:|---:|")
    for row in rows:
        print(f"| {row['coast']} | {row['updates']} | {row['env_steps_per_s']:.3g} | {row['build_s']:.0f} |")
    print(f"fast ÷ default: {ratio:.2f}×")
    if args.out:
        cli.write_whole(args.out, json.dumps({
            "env": flags.env, "recipe": recipe, "rounds": args.rounds, "rows": rows,
            "fast_over_default": ratio, "device": str(jax.devices()[0].device_kind), "machine": machine(),
            "jax": jax.__version__, "date": time.strftime("%Y-%m-%d")}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
