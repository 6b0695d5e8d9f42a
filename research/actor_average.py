"""Does averaging the actor's weights over the last updates make it more precise? A run continued, each actor kept.

    python -m research.actor_average runs/jax/<run>/checkpoint.npz --updates 64 --out research/results/actor_average_uncertain.json

A policy gradient's minibatch steps move the actor's weights by about the learning rate each, in
directions that are partly noise; the mean of the weights over many updates (Polyak & Juditsky 1992;
stochastic weight averaging, Izmailov et al. 2018) keeps their common direction and averages the noise
out. If that noise were what holds the uncertain task's learners at ~80 % (a policy must be right to a
few thousandths of the action's range there: ``research/action_noise.py``), the averaged actor would
score higher than each one it averages.

The script continues a run of ``train_jax.py`` from its checkpoint (a finished one too: its learning rate
then goes on past the annealing's floor, 1e-5 → 0.6e-5 after 64 more updates of a 610-update run), one
update at a time for ``--updates``, keeping each seed's actor after each. It scores every ``--every``-th
actor and the uniform means of the last 4, 8, 16, 32 and 64 on the same ``--episodes`` fresh episodes of
the JAX env (``train_jax.py``'s final episodes), deterministic, and writes them to ``--out`` (a new file).
Its numbers are in docs/learners.md ("Averaged actors, and a GRU with the recipe (eighth
points)").
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import jax
import numpy as np

import train_jax
from agents import cli

#: The lengths of the averages, in updates (those up to ``--updates``).
AVERAGED = (4, 8, 16, 32, 64)


def mean_of_last(actors: list[Any], length: int) -> Any:
    """The actor whose every weight is the mean of that weight over the last ``length`` of ``actors``."""
    return jax.tree.map(lambda *weights: np.mean(weights, axis=0), *actors[-length:])


def main(argv: list[str] | None = None) -> int:
    parser = cli.Parser(prog="python -m research.actor_average", description=cli.describe(__doc__),
                        formatter_class=cli.HelpFormatter)
    parser.add_argument("checkpoint", type=Path, help="a train_jax.py run's checkpoint.npz")
    parser.add_argument("--updates", type=cli.positive_int, default=64, help="updates to continue the run by")
    parser.add_argument("--every", type=cli.positive_int, default=4, help="score every this-many-th actor")
    parser.add_argument("--episodes", type=cli.positive_int, default=train_jax.EVAL_EPISODES,
                        help="fresh JAX episodes each actor is scored on")
    parser.add_argument("--out", type=Path, required=True, help="the results' JSON file (a new one)")
    try:
        args = parser.parse_args(argv)
        if args.out.exists():
            raise cli.UsageError(f"--out {args.out}: exists; results are not overwritten")
        try:
            state, progress = train_jax.load_checkpoint(args.checkpoint)
        except (OSError, ValueError, KeyError) as err:
            raise cli.UsageError(f"{args.checkpoint}: not a checkpoint of train_jax.py ({err})") from err
    except cli.UsageError as err:
        return cli.fail(err)

    config, env_id = train_jax.config_of(progress["config"]), progress["env_id"]
    actors = []
    for _ in range(args.updates):
        state, _ = train_jax.run_chunk(state, env_id, config, 1)
        actors.append(jax.tree.map(np.asarray, state.network["actor"]))

    def score(actor) -> list[float]:  # each seed's success
        return np.asarray(train_jax.deterministic_play(actor, env_id, config, args.episodes,
                                                       train_jax.EVAL_KEY)[0]).tolist()

    results = {"checkpoint": str(args.checkpoint), "env_id": env_id, "seeds": progress["seeds"],
               "from_update": progress["updates"], "episodes": args.episodes, "each": [], "averaged": {}}
    for i in range(0, args.updates, args.every):
        results["each"].append([i + 1, score(actors[i])])
        print(f"the actor after {i + 1} more updates: {results['each'][-1][1]}", flush=True)
    for length in (n for n in AVERAGED if n <= args.updates):
        results["averaged"][length] = score(mean_of_last(actors, length))
        print(f"the mean of the last {length} actors: {results['averaged'][length]}", flush=True)
    cli.write_whole(args.out, json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
