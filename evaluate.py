"""Paired evaluation of agents on a lightsail-gym task (see ``agents.evaluation``)."""

import sys

from agents.evaluation import main

if __name__ == "__main__":
    sys.exit(main())
