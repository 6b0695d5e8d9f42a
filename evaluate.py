"""Paired evaluation of agents on a lightsail-gym task: report.json, episodes.csv, report.md, plots.

    python evaluate.py --agent passive --agent lqr --agent runs/LightSail-v0-ppo-0/best_model.zip
    python evaluate.py --env LightSailRealistic-v0 --agent lqg --agent PATH.zip --episodes 200

``--agent`` is ``passive``, ``lqr``, ``lqg`` or the path of a model saved by ``train.py``
(loaded with the VecNormalize statistics beside it, acting deterministically).
Episode ``i`` is ``env.reset(seed=seed + i)`` for every agent, so all agents face the
same start states, cut-off times and noise draws: the comparison is paired.
"""

import sys

from agents.evaluation import main

if __name__ == "__main__":
    sys.exit(main())
