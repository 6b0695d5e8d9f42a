"""Train a Stable-Baselines3 agent on a lightsail-gym task (RL Baselines3 Zoo conventions).

    python train.py --algo ppo                        # the defaults: a good PPO on LightSail-v0
    python train.py --algo sac --env LightSailDeepDish-v0 --timesteps 200000 --seed 1
    python train.py --resume runs/LightSail-v0-ppo-0  # continue an interrupted run

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (keyed by env id, or
``--config FILE``); flags override them. Everything goes under ``--out``
(default ``runs/<env>-<algo>-<seed>/``):

    run.json                          versions, seed, configuration, command, status
    best_model.zip (+ _vecnormalize.pkl)   best evaluation success rate (mean return breaks ties)
    best_model.json                   when and how well it was evaluated
    final_model.zip (+ _vecnormalize.pkl)  at the end of training
    checkpoints/rl_model_<N>_steps.zip (+ normaliser, replay buffer)   also written on Ctrl-C or SIGTERM
    evaluations.npz, tb/              evaluation history, TensorBoard logs
"""

import sys

from agents.training import main, stop_on_signals

if __name__ == "__main__":
    stop_on_signals()
    sys.exit(main())
