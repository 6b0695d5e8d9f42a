"""Train a Stable-Baselines3 agent on a lightsail-gym task: ``python train.py --algo ppo`` (see ``agents.training``)."""

import sys

from agents.training import main, stop_on_signals

if __name__ == "__main__":
    stop_on_signals()
    sys.exit(main())
